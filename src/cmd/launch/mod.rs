//! `nrslam launch` and `nrslam run`: a graph in one process or one process per node, supervised.

mod args;
mod build;
mod in_process;
mod launch;
mod node;
mod processes;
mod recorder;
mod replay;

pub(crate) use self::args::ROS_DOMAIN_ID;
pub use self::args::{LaunchArgs, RunArgs};
pub(crate) use self::build::build_all;
pub use self::launch::launch;
pub use self::node::run;

use crate::TransportArgs;
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_runtime::transport::{SessionMode, TransportConfig};

fn progress(frames: Option<u64>) -> ProgressBar {
    let bar = match frames {
        Some(n) => ProgressBar::new(n),
        None => ProgressBar::new_spinner(),
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} frames  ETA {eta}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

fn transport_config(mode: SessionMode, args: &TransportArgs) -> TransportConfig {
    args.config(mode)
}
