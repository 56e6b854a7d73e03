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
//!
//! **Size.** A file is streamed, never read whole: one past [`MAX_CSV_BYTES`] bytes or
//! [`MAX_CSV_ROWS`] rows is refused ([`EvaluatorError::TooLarge`]) as soon as the reader gets
//! there, so a 10 GB file costs neither 10 GB of memory nor the time to read it all. Inputs that
//! fit can still hold too many points within c of one another for the dense assignment of their
//! component ([`MAX_CELLS`](crate::assignment::MAX_CELLS) slots × estimates per connected group),
//! which the metrics refuse before allocating.

use std::cell::RefCell;
use std::collections::{HashMap, VecDeque};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use serde::Serialize;
use thiserror::Error;

use crate::error::MetricError;
use crate::etgospa::{etgospa, DistanceMode, EtGospaParams, EtGospaResult, ExtendedTarget};
use crate::gospa::{gospa, GospaResult};
use crate::point::Point2;

/// Parameters of a metric report: c, p, α, the distance mode and `squared_distance`, as for
/// ET-GOPSA; GOSPA uses c, p, α.
pub type MetricParams = EtGospaParams;

/// Largest CSV file read, in bytes (1 GiB).
pub const MAX_CSV_BYTES: u64 = 1 << 30;

/// Most data rows read from one CSV file (2^24 = 16 777 216 points, 256 MiB as points).
pub const MAX_CSV_ROWS: u64 = 1 << 24;

/// The size limits of one read (the constants above; smaller in the tests).
#[derive(Debug, Clone, Copy)]
struct Limits {
    bytes: u64,
    rows: u64,
}

const LIMITS: Limits = Limits {
    bytes: MAX_CSV_BYTES,
    rows: MAX_CSV_ROWS,
};

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
    /// The file is past [`MAX_CSV_BYTES`] bytes or [`MAX_CSV_ROWS`] rows (refused while
    /// streaming: the rest is not read).
    #[error("{}: more than {limit} {what}: too large for `nrslam metric`", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The limit passed.
        limit: u64,
        /// `bytes` or `rows`.
        what: &'static str,
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
    read_truth_within(path, LIMITS)
}

fn read_truth_within(path: &Path, limits: Limits) -> Result<Vec<TruthTarget>, EvaluatorError> {
    let mut table = Table::open(path, &["target", "x", "y"], TRUTH_HEADER, limits)?;
    let mut targets: Vec<TruthTarget> = Vec::new();
    // Position in `targets` of each id: targets stay in first-appearance order.
    let mut index: HashMap<String, usize> = HashMap::new();
    while let Some(row) = table.next_row()? {
        let id = row.text(0)?;
        let point = Point2::new(row.number(1)?, row.number(2)?);
        match index.get(id) {
            Some(&k) => targets[k].samples.push(point),
            None => {
                index.insert(id.to_owned(), targets.len());
                targets.push(TruthTarget {
                    id: id.to_owned(),
                    samples: vec![point],
                });
            }
        }
    }
    Ok(targets)
}

/// Reads an estimates file (`x,y`).
///
/// # Errors
/// See [`EvaluatorError`].
pub fn read_estimates(path: &Path) -> Result<Vec<Point2>, EvaluatorError> {
    read_estimates_within(path, LIMITS)
}

fn read_estimates_within(path: &Path, limits: Limits) -> Result<Vec<Point2>, EvaluatorError> {
    let mut table = Table::open(path, &["x", "y"], ESTIMATES_HEADER, limits)?;
    let mut points = Vec::new();
    while let Some(row) = table.next_row()? {
        points.push(Point2::new(row.number(0)?, row.number(1)?));
    }
    Ok(points)
}

/// A CSV file whose required columns have been located in its header.
struct Table<'a> {
    path: &'a Path,
    reader: csv::Reader<Tracked>,
    /// Where the lines near the reader start and whether they are blank, for line numbers: the
    /// csv crate skips blank lines without counting them, and a record's byte position points
    /// before them.
    lines: Rc<RefCell<Lines>>,
    /// Data rows read so far.
    rows: u64,
    /// Most data rows read.
    max_rows: u64,
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
        limits: Limits,
    ) -> Result<Self, EvaluatorError> {
        let file = std::fs::File::open(path).map_err(|source| EvaluatorError::Io {
            path: path.to_owned(),
            source,
        })?;
        let lines = Rc::new(RefCell::new(Lines {
            max_bytes: limits.bytes,
            ..Lines::default()
        }));
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            // Short rows are reported by us, naming the missing column.
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(Tracked {
                inner: std::io::BufReader::new(file).take(limits.bytes.saturating_add(1)),
                lines: lines.clone(),
            });
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
                line: lines.borrow_mut().line_of(header.position()),
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
            rows: 0,
            max_rows: limits.rows,
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
        self.rows += 1;
        if self.rows > self.max_rows {
            return Err(EvaluatorError::TooLarge {
                path: self.path.to_owned(),
                limit: self.max_rows,
                what: "rows",
            });
        }
        let line = self.lines.borrow_mut().line_of(self.record.position());
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

/// The file as the csv reader reads it, its lines tracked on the way.
struct Tracked {
    inner: std::io::Take<std::io::BufReader<std::fs::File>>,
    lines: Rc<RefCell<Lines>>,
}

impl Read for Tracked {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        let mut lines = self.lines.borrow_mut();
        lines.feed(&buf[..n]);
        if lines.bytes > lines.max_bytes {
            lines.too_large = true;
            return Err(std::io::Error::other("file too large"));
        }
        Ok(n)
    }
}

/// Line starts and blank lines of the part of a file around the reader: lines wholly before the
/// last position asked about are dropped, so memory stays that of the csv reader's buffer.
#[derive(Debug, Default)]
struct Lines {
    /// Bytes fed so far.
    bytes: u64,
    /// Most bytes read.
    max_bytes: u64,
    /// The file went past `max_bytes`.
    too_large: bool,
    /// Complete lines not dropped yet: (start byte, blank), the first being line `first_line`.
    window: VecDeque<(u64, bool)>,
    /// 1-based number of `window[0]` (or of the current line when the window is empty).
    first_line: u64,
    /// Start of the line being fed, and whether it is blank so far.
    current: (u64, bool),
}

impl Lines {
    fn feed(&mut self, bytes: &[u8]) {
        if self.first_line == 0 {
            self.first_line = 1;
            self.current = (0, true);
        }
        for &b in bytes {
            self.bytes += 1;
            match b {
                b'\n' => {
                    self.window.push_back(self.current);
                    self.current = (self.bytes, true);
                }
                b'\r' => {}
                _ => self.current.1 = false,
            }
        }
    }

    /// 1-based line of the record whose csv position is `position` (0 if unknown): the line
    /// holding that byte, moved past the blank lines the csv reader skipped. Positions asked
    /// about must not decrease (the reader only moves forward).
    fn line_of(&mut self, position: Option<&csv::Position>) -> u64 {
        let Some(position) = position else { return 0 };
        let byte = position.byte();
        self.first_line = self.first_line.max(1);
        // Drop the lines that end before `byte` (the next line starts at or before it).
        while !self.window.is_empty() {
            let next_start = self.window.get(1).map_or(self.current.0, |l| l.0);
            if next_start > byte {
                break;
            }
            self.window.pop_front();
            self.first_line += 1;
        }
        // Then past the blank lines the reader skipped, while a line follows.
        let skipped = self.window.iter().take_while(|l| l.1).count();
        self.first_line + skipped as u64
    }
}

fn csv_error(path: &Path, lines: &RefCell<Lines>, error: csv::Error) -> EvaluatorError {
    if lines.borrow().too_large {
        return EvaluatorError::TooLarge {
            path: path.to_owned(),
            limit: lines.borrow().max_bytes,
            what: "bytes",
        };
    }
    let line = lines.borrow_mut().line_of(error.position());
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

#[cfg(test)]
mod tests {
    use super::*;

    fn file(text: &str) -> tempfile::NamedTempFile {
        let file = tempfile::NamedTempFile::new().unwrap();
        std::fs::write(file.path(), text).unwrap();
        file
    }

    #[test]
    fn files_past_the_row_or_byte_limit_are_refused_while_streaming() {
        let rows: String = (0..100).map(|k| format!("{k},0\n")).collect();
        let estimates = file(&format!("x,y\n{rows}"));
        let roomy = Limits {
            bytes: 1 << 20,
            rows: 100,
        };
        assert_eq!(
            read_estimates_within(estimates.path(), roomy)
                .unwrap()
                .len(),
            100
        );
        let error = read_estimates_within(estimates.path(), Limits { rows: 99, ..roomy })
            .unwrap_err()
            .to_string();
        assert!(
            error.ends_with("more than 99 rows: too large for `nrslam metric`"),
            "{error}"
        );
        let error = read_estimates_within(estimates.path(), Limits { bytes: 64, ..roomy })
            .unwrap_err()
            .to_string();
        assert!(error.contains("more than 64 bytes"), "{error}");
        let truth = file("target,x,y\na,0,0\nb,1,1\na,2,2\n");
        let error = read_truth_within(truth.path(), Limits { rows: 2, ..roomy })
            .unwrap_err()
            .to_string();
        assert!(error.contains("more than 2 rows"), "{error}");
        let targets = read_truth_within(truth.path(), roomy).unwrap();
        assert_eq!(
            targets
                .iter()
                .map(|t| (t.id.as_str(), t.samples.len()))
                .collect::<Vec<_>>(),
            [("a", 2), ("b", 1)]
        );
    }

    #[test]
    fn line_numbers_hold_across_blank_lines_and_reader_buffers() {
        // Blank lines before a bad row, and far enough into the file that the reader has
        // refilled its buffer many times.
        let mut text = "x,y\n".to_owned();
        for k in 0..20_000 {
            text.push_str(&format!("{k},1\n"));
            if k % 7 == 0 {
                text.push_str("\r\n\n");
            }
        }
        let lines_before = text.matches('\n').count();
        text.push_str("\n\n5,abc\n");
        let error = read_estimates(file(&text).path()).unwrap_err().to_string();
        assert!(
            error.contains(&format!("line {}, column `y`", lines_before + 3)),
            "{error}"
        );
    }
}
