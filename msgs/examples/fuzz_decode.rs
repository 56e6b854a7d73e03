//! Long fuzz run of the CDR decoder: N inputs (default 1,000,000) across every catalogue type,
//! from a fixed seed, each decoded as its type and, if it decodes, checked with
//! `Message::check_usable` — the runtime's receive path. Inputs are random bytes and mutated
//! valid encodings (`tests/common/mod.rs`). Reports the counts and the time; exits with status 1
//! if any input panicked (caught with `catch_unwind`, printed with its index to reproduce it).
//!
//! ```text
//! cargo run --release -p nrslam-msgs --example fuzz_decode -- [inputs] [seed]
//! /usr/bin/time -v target/release/examples/fuzz_decode 1000000   # peak RSS
//! ```

#[path = "../tests/common/mod.rs"]
mod common;

use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let parse = |arg: Option<String>, default: u64, what: &str| -> Result<u64, String> {
        arg.map_or(Ok(default), |a| {
            a.replace('_', "")
                .parse()
                .map_err(|e| format!("{what} {a:?}: {e}"))
        })
    };
    let (inputs, seed) = match (
        parse(args.next(), 1_000_000, "inputs"),
        parse(args.next(), 0x5eed, "seed"),
    ) {
        (Ok(inputs), Ok(seed)) => (inputs, seed),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("usage: fuzz_decode [inputs] [seed]: {e}");
            return ExitCode::from(2);
        }
    };

    let mut rng = common::Rng::new(seed);
    let (mut ok, mut err, mut panics, mut bytes_total) = (0u64, 0u64, 0u64, 0u64);
    let mut largest_input = 0usize;
    let started = Instant::now();
    for index in 0..inputs {
        let (type_name, bytes) = common::fuzz_input(&mut rng);
        bytes_total += bytes.len() as u64;
        largest_input = largest_input.max(bytes.len());
        match std::panic::catch_unwind(|| common::receive(type_name, &bytes)) {
            Ok(true) => ok += 1,
            Ok(false) => err += 1,
            Err(_) => {
                panics += 1;
                eprintln!("panic on input {index} ({type_name}, seed {seed}): {bytes:02x?}");
            }
        }
    }
    let elapsed_s = started.elapsed().as_secs_f64();
    println!(
        "inputs {inputs} (seed {seed:#x}, {} types, {bytes_total} bytes, largest {largest_input}): \
         ok {ok}, err {err}, panics {panics}; {elapsed_s:.2} s ({:.2} µs/input)",
        nrslam_msgs::Message::TYPE_NAMES.len(),
        elapsed_s * 1e6 / inputs.max(1) as f64
    );
    if panics > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
