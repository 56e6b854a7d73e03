//! What a sizing study keeps on disk, so that a study killed at any point resumes where it
//! stopped: `requirement.toml` (the study's identity) and `trials/<config>.csv`, each
//! configuration's trials in index order, rewritten whole (write, then rename) after every
//! completed batch. A batch cut off by a kill is run again: the same seeds give the same values.

use super::trial::METRICS;
use anyhow::{anyhow, bail, Context, Result};
use std::path::{Path, PathBuf};

/// The study folder.
pub struct Store {
    dir: PathBuf,
}

/// Writes `text` to `path` by a rename, so a reader (or a study resumed after a kill) sees the
/// old file or the new one, never a part.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".tmp{}", std::process::id()));
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
}

impl Store {
    /// Opens (creating) the study folder for `identity`, the requirement as canonical TOML; a
    /// folder holding another study is refused.
    pub fn open(dir: &Path, identity: &str) -> Result<Self> {
        std::fs::create_dir_all(dir.join("trials"))
            .with_context(|| format!("cannot create {}", dir.join("trials").display()))?;
        let path = dir.join("requirement.toml");
        match std::fs::read_to_string(&path) {
            Ok(existing) if existing == identity => {}
            Ok(_) => bail!(
                "{} holds a study of another requirement ({}): give another --out, or remove \
                 the folder to start over",
                dir.display(),
                path.display()
            ),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                write_atomically(&path, identity.as_bytes())?
            }
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        }
        Ok(Self {
            dir: dir.to_owned(),
        })
    }

    fn trials_path(&self, id: &str) -> PathBuf {
        self.dir.join("trials").join(format!("{id}.csv"))
    }

    /// The trials kept for configuration `id`, trial 0 first (none if it has no file yet).
    /// A file that is not what [`Store::save`] writes is refused, naming the line.
    pub fn load(&self, id: &str) -> Result<Vec<[f64; 5]>> {
        let path = self.trials_path(id);
        let text = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        };
        let mut lines = text.lines();
        if lines.next() != Some(header().as_str()) {
            bail!(
                "{}: not a sizing trials file (its header differs); remove it to run that \
                 configuration again",
                path.display()
            );
        }
        let mut trials = Vec::new();
        for (i, line) in lines.enumerate() {
            let bad = || {
                anyhow!(
                    "{}: line {} is damaged; remove the file to run that configuration again",
                    path.display(),
                    i + 2
                )
            };
            let fields: Vec<&str> = line.split(',').collect();
            if fields.len() != 1 + METRICS.len() || fields[0].parse::<usize>().ok() != Some(i) {
                return Err(bad());
            }
            let mut summary = [0.0; 5];
            for (value, field) in summary.iter_mut().zip(&fields[1..]) {
                *value = field.parse().map_err(|_| bad())?;
            }
            trials.push(summary);
        }
        Ok(trials)
    }

    /// Replaces configuration `id`'s file with `trials`.
    pub fn save(&self, id: &str, trials: &[[f64; 5]]) -> Result<()> {
        let mut text = header();
        text.push('\n');
        for (i, summary) in trials.iter().enumerate() {
            text.push_str(&i.to_string());
            for value in summary {
                text.push(',');
                text.push_str(&value.to_string());
            }
            text.push('\n');
        }
        write_atomically(&self.trials_path(id), text.as_bytes())
    }
}

fn header() -> String {
    let mut header = "trial".to_owned();
    for metric in METRICS {
        header.push(',');
        header.push_str(metric.name());
    }
    header
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trials_round_trip_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path(), "a").unwrap();
        let trials = vec![
            [0.1, 1.0 / 3.0, 2.5, 17.25, f64::MIN_POSITIVE],
            [1e-300, 0.0, 5.0, 1e300, 3.0],
        ];
        store.save("x", &trials).unwrap();
        assert_eq!(store.load("x").unwrap(), trials);
        assert!(store.load("absent").unwrap().is_empty());
    }

    #[test]
    fn another_study_and_damaged_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        Store::open(dir.path(), "a").unwrap();
        let error = Store::open(dir.path(), "b").err().unwrap().to_string();
        assert!(error.contains("another requirement"), "{error}");
        let store = Store::open(dir.path(), "a").unwrap();
        store.save("x", &[[1.0; 5], [2.0; 5]]).unwrap();
        let path = dir.path().join("trials/x.csv");
        let text = std::fs::read_to_string(&path).unwrap();
        // Truncated mid-line, or rows out of order.
        std::fs::write(&path, &text[..text.len() - 4]).unwrap();
        assert!(store.load("x").is_err());
        std::fs::write(&path, text.replace("\n1,", "\n7,")).unwrap();
        assert!(store.load("x").unwrap_err().to_string().contains("line 3"));
    }
}
