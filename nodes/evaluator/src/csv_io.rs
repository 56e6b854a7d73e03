//! Metrics from user CSV files, for `nrslam metric --truth FILE --estimates FILE [--json]`.
//!
//! - Truth: header `target,x,y`, one row per sample point; `target` is any id (string or
//!   integer, compared as trimmed text). Rows with the same id form one target; targets are
//!   numbered in order of first appearance, samples kept in file order. Each target gets one
//!   slot per sample (the paper's 4 samples per target, Sec. IV-C), and with
//!   `distance = "outline"` its samples, in file order, are the vertices of its closed outline.
//! - Estimates: header `x,y`, one row per estimate point.
//!
//! Columns are found by header name (case-insensitive, surrounding spaces ignored), other columns
//! are ignored. Coordinates are metres. GOSPA is computed between all truth sample points and the
//! estimates, ET-GOPSA between the targets and the estimates, both with the same c, p, α
//! (GOSPA always with the plain Euclidean distance).
//!
//! Errors name the file, the line and the column.

use std::path::{Path, PathBuf};

use serde::Serialize;
use thiserror::Error;

use crate::error::MetricError;
use crate::etgospa::{etgospa, DistanceMode, EtGospaParams, EtGospaResult, ExtendedTarget};
use crate::gospa::{gospa, GospaResult};
use crate::point::Point2;

/// Parameters of a metric report: c, p, α, the distance mode and `squared_distance`, as for
/// ET-GOPSA; GOSPA uses c, p, α.
pub type MetricParams = EtGospaParams;

/// Why `evaluate_files` failed.
#[derive(Debug, Error)]
pub enum EvaluatorError {
    /// The file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid CSV (for instance not UTF-8).
    #[error("{}, line {line}: {problem}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line number (0 when the CSV reader could not tell).
        line: u64,
        /// What the CSV reader reported.
        problem: String,
    },
    /// The file is empty: no header row.
    #[error("{}: empty file, expected a header row `{expected}`", path.display())]
    MissingHeader {
        /// The file.
        path: PathBuf,
        /// The expected header.
        expected: &'static str,
    },
    /// The header lacks a required column or repeats one.
    #[error("{}, line {line}: {problem} (expected header `{expected}`)", path.display())]
    BadHeader {
        /// The file.
        path: PathBuf,
        /// 1-based line of the header row.
        line: u64,
        /// What is wrong.
        problem: String,
        /// The expected header.
        expected: &'static str,
    },
    /// A field is missing, empty, not a number or not finite.
    #[error("{}, line {line}, column `{column}`: {problem}", path.display())]
    BadField {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// The column's header name.
        column: &'static str,
        /// What is wrong with the field.
        problem: String,
    },
    /// The metric refused its parameters or input.
    #[error(transparent)]
    Metric(#[from] MetricError),
}

/// One truth target read from a CSV file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruthTarget {
    /// Its id, as written in the `target` column (trimmed).
    pub id: String,
    /// Its sample points in file order, metres.
    pub samples: Vec<Point2>,
}

/// GOSPA and ET-GOPSA of one truth/estimates pair, serialisable for `--json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetricReport {
    /// The parameters used (a p = ∞ serialises as JSON `null`).
    pub params: MetricParams,
    /// Number of truth targets.
    pub target_count: usize,
    /// Number of truth sample points (the GOSPA truth set).
    pub truth_point_count: usize,
    /// Number of estimate points.
    pub estimate_count: usize,
    /// GOSPA between all truth sample points and the estimates.
    pub gospa: GospaResult,
    /// ET-GOPSA between the truth targets and the estimates.
    pub etgospa: EtGospaResult,
}

const TRUTH_HEADER: &str = "target,x,y";
const ESTIMATES_HEADER: &str = "x,y";

/// Reads the truth file and the estimates file and computes both metrics.
///
/// # Errors
/// [`EvaluatorError`] naming the file, line and column of bad input, or the metric's error for
/// bad parameters.
pub fn evaluate_files(
    truth: &Path,
    estimates: &Path,
    params: &MetricParams,
) -> Result<MetricReport, EvaluatorError> {
    // Check the parameters first: a typo in c should not wait for a large file to be parsed.
    params.validate().map_err(MetricError::from)?;
    let targets = read_truth(truth)?;
    let estimates = read_estimates(estimates)?;
    Ok(evaluate(&targets, &estimates, params)?)
}

/// Both metrics for targets already read (see the module doc for how they are scored).
///
/// # Errors
/// As [`gospa`] and [`etgospa`].
pub fn evaluate(
    targets: &[TruthTarget],
    estimates: &[Point2],
    params: &MetricParams,
) -> Result<MetricReport, MetricError> {
    let all_samples: Vec<Point2> = targets
        .iter()
        .flat_map(|t| t.samples.iter().copied())
        .collect();
    let extended: Vec<ExtendedTarget> = targets
        .iter()
        .map(|t| {
            let target = ExtendedTarget::from_samples(t.samples.clone());
            match params.distance {
                DistanceMode::Samples => target,
                DistanceMode::Outline => target.with_outline(t.samples.clone()),
            }
        })
        .collect();
    Ok(MetricReport {
        params: *params,
        target_count: targets.len(),
        truth_point_count: all_samples.len(),
        estimate_count: estimates.len(),
        gospa: gospa(&all_samples, estimates, &params.gospa())?,
        etgospa: etgospa(&extended, estimates, params)?,
    })
}

/// Reads a truth file (`target,x,y`), grouping rows by target id in first-appearance order.
///
/// # Errors
/// See [`EvaluatorError`].
pub fn read_truth(path: &Path) -> Result<Vec<TruthTarget>, EvaluatorError> {
    let mut table = Table::open(path, &["target", "x", "y"], TRUTH_HEADER)?;
    let mut targets: Vec<TruthTarget> = Vec::new();
    while let Some(row) = table.next_row()? {
        let id = row.text(0)?.to_owned();
        let point = Point2::new(row.number(1)?, row.number(2)?);
        // Linear search keeps first-appearance order; a HashMap index would need the same Vec.
        match targets.iter_mut().find(|t| t.id == id) {
            Some(target) => target.samples.push(point),
            None => targets.push(TruthTarget {
                id,
                samples: vec![point],
            }),
        }
    }
    Ok(targets)
}

/// Reads an estimates file (`x,y`).
///
/// # Errors
/// See [`EvaluatorError`].
pub fn read_estimates(path: &Path) -> Result<Vec<Point2>, EvaluatorError> {
    let mut table = Table::open(path, &["x", "y"], ESTIMATES_HEADER)?;
    let mut points = Vec::new();
    while let Some(row) = table.next_row()? {
        points.push(Point2::new(row.number(0)?, row.number(1)?));
    }
    Ok(points)
}

/// A CSV file whose required columns have been located in its header.
struct Table<'a> {
    path: &'a Path,
    reader: csv::Reader<std::io::Cursor<Vec<u8>>>,
    /// Where each line starts and whether it is blank, for line numbers: the csv crate skips
    /// blank lines without counting them, and a record's byte position points before them.
    lines: Lines,
    columns: &'static [&'static str],
    /// Position of each required column in the file's records.
    positions: Vec<usize>,
    record: csv::StringRecord,
}

/// The current record of a [`Table`].
struct Row<'t, 'a> {
    table: &'t Table<'a>,
    line: u64,
}

impl<'a> Table<'a> {
    fn open(
        path: &'a Path,
        columns: &'static [&'static str],
        expected: &'static str,
    ) -> Result<Self, EvaluatorError> {
        let bytes = std::fs::read(path).map_err(|source| EvaluatorError::Io {
            path: path.to_owned(),
            source,
        })?;
        let lines = Lines::new(&bytes);
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            // Short rows are reported by us, naming the missing column.
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(std::io::Cursor::new(bytes));
        let header = match reader.headers() {
            Ok(header) => header.clone(),
            Err(e) => return Err(csv_error(path, &lines, e)),
        };
        if header.is_empty() {
            return Err(EvaluatorError::MissingHeader {
                path: path.to_owned(),
                expected,
            });
        }
        let mut positions = Vec::with_capacity(columns.len());
        for &column in columns {
            let mut found = header
                .iter()
                .enumerate()
                .filter(|(_, name)| name.eq_ignore_ascii_case(column))
                .map(|(k, _)| k);
            let bad_header = |problem: String| EvaluatorError::BadHeader {
                path: path.to_owned(),
                line: lines.line_of(header.position()),
                problem,
                expected,
            };
            match (found.next(), found.next()) {
                (Some(k), None) => positions.push(k),
                (None, _) => {
                    return Err(bad_header(format!(
                        "no column `{column}` in header `{}`",
                        header.iter().collect::<Vec<_>>().join(",")
                    )))
                }
                (Some(_), Some(_)) => {
                    return Err(bad_header(format!("column `{column}` appears twice")))
                }
            }
        }
        Ok(Self {
            path,
            reader,
            lines,
            columns,
            positions,
            record: csv::StringRecord::new(),
        })
    }

    fn next_row(&mut self) -> Result<Option<Row<'_, 'a>>, EvaluatorError> {
        let more = match self.reader.read_record(&mut self.record) {
            Ok(more) => more,
            Err(e) => return Err(csv_error(self.path, &self.lines, e)),
        };
        if !more {
            return Ok(None);
        }
        let line = self.lines.line_of(self.record.position());
        Ok(Some(Row {
            table: &*self,
            line,
        }))
    }
}

impl Row<'_, '_> {
    fn bad(&self, k: usize, problem: String) -> EvaluatorError {
        EvaluatorError::BadField {
            path: self.table.path.to_owned(),
            line: self.line,
            column: self.table.columns[k],
            problem,
        }
    }

    /// Required column k as non-empty text.
    fn text(&self, k: usize) -> Result<&str, EvaluatorError> {
        match self.table.record.get(self.table.positions[k]) {
            None => Err(self.bad(k, "missing value (row too short)".to_owned())),
            Some("") => Err(self.bad(k, "empty value".to_owned())),
            Some(text) => Ok(text),
        }
    }

    /// Required column k as a finite number.
    fn number(&self, k: usize) -> Result<f64, EvaluatorError> {
        let text = self.text(k)?;
        match text.parse::<f64>() {
            Ok(value) if value.is_finite() => Ok(value),
            // Rust parses "NaN" and "inf": refuse them here, with the line, not later in the
            // metric with only an index.
            Ok(value) => Err(self.bad(k, format!("{value} is not a finite number"))),
            Err(_) => Err(self.bad(k, format!("cannot parse `{text}` as a number"))),
        }
    }
}

/// Line starts and blank lines of a file.
struct Lines {
    /// Byte offset where each line starts (line k + 1 starts at starts[k]).
    starts: Vec<u64>,
    /// Whether each line is empty (apart from a carriage return).
    blank: Vec<bool>,
}

impl Lines {
    fn new(bytes: &[u8]) -> Self {
        let mut starts = vec![0u64];
        let mut blank = Vec::new();
        let mut line_start = 0usize;
        for (k, &b) in bytes.iter().enumerate() {
            if b == b'\n' {
                blank.push(matches!(&bytes[line_start..k], [] | [b'\r']));
                line_start = k + 1;
                starts.push(line_start as u64);
            }
        }
        blank.push(bytes[line_start..].iter().all(|&b| b == b'\r'));
        Self { starts, blank }
    }

    /// 1-based line of the record whose csv position is `position` (0 if unknown): the line
    /// holding that byte, moved past the blank lines the csv reader skipped.
    fn line_of(&self, position: Option<&csv::Position>) -> u64 {
        let Some(position) = position else { return 0 };
        let mut line = self
            .starts
            .partition_point(|&start| start <= position.byte())
            .saturating_sub(1);
        while line + 1 < self.blank.len() && self.blank[line] {
            line += 1;
        }
        line as u64 + 1
    }
}

fn csv_error(path: &Path, lines: &Lines, error: csv::Error) -> EvaluatorError {
    let line = lines.line_of(error.position());
    let problem = error.to_string();
    match error.into_kind() {
        csv::ErrorKind::Io(source) => EvaluatorError::Io {
            path: path.to_owned(),
            source,
        },
        _ => EvaluatorError::Csv {
            path: path.to_owned(),
            line,
            problem,
        },
    }
}
