//! The specification the flag tests check against: a valid base command line per verb, the
//! allowed range of every numeric flag, and the extreme values fed to each flag.

/// A valid command line for each verb (path of subcommand names, then arguments); a flag under
/// test replaces its own entry here.
pub(super) const BASE: &[(&str, &[&str])] = &[
    ("launch", &["launch/paper-ideal.toml"]),
    ("run", &["radar"]),
    ("topics", &[]),
    ("echo", &["/clock"]),
    ("metric", &["--truth", "t.csv", "--estimates", "e.csv"]),
    (
        "segment",
        &["--input", "i.csv", "--eps", "1", "--min-samples", "2"],
    ),
    ("accuracy", &["--out", "o"]),
    ("resolution", &["--out", "o"]),
    ("montecarlo", &["l.toml", "--trials", "2", "--out", "o"]),
    ("merge", &["a", "--out", "o"]),
    ("reproduce", &["--out", "o"]),
    ("tradeoff", &["--out", "o"]),
    ("scene", &["--random", "--out", "o"]),
    ("sizing", &["r.toml", "--out", "o"]),
    ("bag record", &["d"]),
    ("bag info", &["d"]),
    ("bag play", &["d"]),
];

/// What a numeric flag accepts.
#[derive(Debug, Clone, Copy)]
pub(super) enum Range {
    /// Finite reals in [min, max] (`min` excluded when `open`), plus 0 when `zero`.
    Real {
        min: f64,
        max: f64,
        open: bool,
        zero: bool,
    },
    /// Whole numbers in [min, max].
    Whole { min: u128, max: u128 },
    /// Not this test's to say (the flag belongs to `nrslam bag`, src/cmd/bag/): only "no panic,
    /// one line naming the flag".
    Unchecked,
}

const fn real(min: f64, max: f64) -> Range {
    Range::Real {
        min,
        max,
        open: false,
        zero: false,
    }
}

const fn whole(min: u128, max: u128) -> Range {
    Range::Whole { min, max }
}

const SEED: Range = whole(0, u64::MAX as u128);
const RATE: Range = Range::Real {
    min: 1e-6,
    max: 1e6,
    open: false,
    zero: true,
};
const WEEK_S: u128 = 604_800;

/// The allowed range of every numeric flag: (verb, flag, range).
pub(super) const RANGES: &[(&str, &str, Range)] = &[
    ("launch", "--seed", SEED),
    ("launch", "--rate", RATE),
    ("launch", "--start-timeout-s", whole(1, WEEK_S)),
    ("launch", "--chunk-size-kib", whole(1, 1 << 20)),
    ("launch", "--ros-domain-id", whole(0, 232)),
    ("launch", "--external-idle-s", real(0.001, 86_400.0)),
    ("run", "--ros-domain-id", whole(0, 232)),
    ("echo", "--ros-domain-id", whole(0, 232)),
    ("topics", "--ros-domain-id", whole(0, 232)),
    ("bag record", "--ros-domain-id", whole(0, 232)),
    ("run", "--seed", SEED),
    ("run", "--start-timeout-s", whole(1, WEEK_S)),
    ("run", "--startup-delay-s", real(0.0, 3600.0)),
    ("run", "--rate", RATE),
    ("topics", "--duration-s", real(1e-3, 3600.0)),
    ("echo", "--count", whole(0, u64::MAX as u128)),
    ("metric", "--c", real(1e-12, 1e12)),
    // 0 < α ≤ 2, and c^p/α ≤ 1e100: with the default c = 5, p = 1, α ≥ 5e-100.
    ("metric", "--alpha", real(5e-100, 2.0)),
    ("segment", "--eps", real(0.0, 1e9)),
    ("segment", "--min-samples", whole(1, u32::MAX as u128)),
    ("accuracy", "--trials", whole(1, 1_000_000)),
    ("accuracy", "--seed", SEED),
    // N × K ≤ 2^28 with the other at its default (K = 32, N = 10240).
    ("accuracy", "--subcarriers", whole(1, (1 << 28) / 32)),
    ("accuracy", "--antennas", whole(1, 4096)),
    ("resolution", "--snr-db", real(-50.0, 100.0)),
    ("resolution", "--trials", whole(1, 100_000)),
    ("resolution", "--points", whole(2, 200)),
    ("resolution", "--seed", SEED),
    ("resolution", "--subcarriers", whole(16, 65_536)),
    ("resolution", "--antennas", whole(2, 1024)),
    ("montecarlo", "--trials", whole(1, 100_000)),
    ("montecarlo", "--seed", SEED),
    ("montecarlo", "--threads", whole(1, 1024)),
    ("reproduce", "--trials", whole(1, 100_000)),
    ("reproduce", "--seed", SEED),
    ("reproduce", "--frames", whole(0, 1_000_000)),
    ("tradeoff", "--trials", whole(1, 1000)),
    ("tradeoff", "--frames", whole(0, 1_000_000)),
    ("tradeoff", "--sensing-trials", whole(1, 1_000_000)),
    ("tradeoff", "--snr-db", real(-100.0, 100.0)),
    ("tradeoff", "--seed", SEED),
    ("sizing", "--threads", whole(1, 1024)),
    ("scene", "--seed", SEED),
    ("scene", "--circle-fraction", real(0.0, 1.0)),
    ("scene", "--target-gap-m", real(0.1, 100.0)),
    ("scene", "--agvs", whole(1, 16)),
    ("scene", "--stations", whole(0, 16)),
    ("bag record", "--duration-s", Range::Unchecked),
    ("bag record", "--chunk-size-kib", Range::Unchecked),
    // 0 (one file) or 1024 to 2^50 bytes: a gap this test's ranges cannot say.
    ("bag record", "--max-bag-size", Range::Unchecked),
    ("bag record", "--max-bag-duration", real(0.0, 604_800.0)),
    ("launch", "--max-bag-size", Range::Unchecked),
    ("launch", "--max-bag-duration", real(0.0, 604_800.0)),
    ("bag play", "--rate", Range::Unchecked),
    ("bag play", "--start-offset", real(0.0, 31_536_000.0)),
    ("bag play", "--clock", real(0.001, 10_000.0)),
    ("bag play", "--match-timeout-s", Range::Unchecked),
    ("bag play", "--ros-domain-id", Range::Unchecked),
];

/// Values from the edges of every numeric type, as typed on a command line.
pub(super) const EXTREMES: &[&str] = &[
    "0",
    "-0",
    "+0",
    "0.0",
    "-0.0",
    "1",
    "-1",
    "2",
    "0.5",
    "1e-300",
    "-1e-300",
    "4.9e-324",
    "1e-6",
    "1e-7",
    "1e6",
    "1e300",
    "-1e300",
    "1.7976931348623157e308",
    "1e309",
    "NaN",
    "nan",
    "-NaN",
    "inf",
    "-inf",
    "infinity",
    "232",
    "233",
    "3600",
    "3601",
    "604800",
    "604801",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "-18446744073709551615",
    "340282366920938463463374607431768211456",
    "99999999999999999999999999999999999999999999999999",
    "1e19",
    "1.5",
    "0x10",
    "",
    " ",
    "five",
    "--rate",
    "1:2",
    "∞",
];
