//! The estimator: FFT plans and buffers made once, then one frame at a time.

use std::f64::consts::PI;
use std::sync::Arc;

use nrslam_ofdm::{OfdmParams, RangeAngleSpectrum, ResourceGrid};
use nrslam_runtime::InvalidParam;
use num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use serde::{Deserialize, Serialize};

use crate::config::{EstimatorConfig, Refinement};
use crate::detect::{DetectScratch, Lobes, MapView, Peak};
use crate::error::EstimatorError;
use crate::kernels::{self, Isa};
use crate::refine;
use crate::superres::{self, CellSolver, Subspace};

const ZERO: Complex64 = Complex64 { re: 0.0, im: 0.0 };

/// Complex cells per angle-transform tile: 64 range bins × 32 angles (32 KiB) at Table I.
const TILE_CELLS: usize = 2048;

/// Largest K · M · N · zero padding the estimator accepts (2³⁰ cells = 16 GiB of work buffer).
const MAX_WORK_CELLS: usize = 1 << 30;

/// Complex cells (one 64-byte cache line) added to each work row; see `Estimator::stride`.
const ROW_PAD: usize = 4;

/// One detected scatterer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RangeAngleDetection {
    /// Range (m), modulo the unambiguous range R_u = c/(2Δf), in [0, R_u − Δr/2]: a refined
    /// position below 0 (a peak at bin 0 with a negative sub-bin offset) is reported as 0, so an
    /// echo within half a bin below R_u (or a multiple of it) appears at 0, never at R_u − ε.
    pub range_m: f64,
    /// Angle from boresight, counter-clockwise positive (rad), in [−π/2, π/2]:
    /// sin θ = s · (2/A) / (2d/λ) with s the signed angle bin (plus its sub-bin offset) and A the
    /// (padded) number of angle bins.
    pub angle_rad: f64,
    /// Power of the peak cell, 10·log10|S|² in map units (a unit echo at a bin centre peaks at
    /// |S| = K: range IDFT scaled 1/N, Doppler DFT scaled 1/M, array DFT unscaled — the
    /// normalisation of `nrslam_ofdm`).
    pub power_db: f64,
    /// Range bin of the peak (in the padded grid: range = bin · range_bin_m before refinement).
    pub range_bin: usize,
    /// Angle bin of the peak after fftshift: broadside is A/2 (the `RangeAngleSpectrum` order).
    pub angle_bin: usize,
    /// The detection's own standard deviations, from a super-resolution method (its Cramér–Rao
    /// bound at the detection's SNR with a model floor); `None` for a DFT-grid peak, whose spread
    /// is its resolution cell's (`crate::node::cell_detection`).
    pub std: Option<DetectionStd>,
}

/// Standard deviations of one detection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DetectionStd {
    /// Range std (m).
    pub range_m: f64,
    /// Angle std (rad).
    pub angle_rad: f64,
}

/// The range-angle estimator of paper Sec. III-B.
///
/// Sign conventions (shared with the `waveform` front end): an echo at range r and angle θ is
/// Y(k, m, n) = a · X(m, n) · e^(−j2π nΔf · 2r/c) · e^(+j2π (d/λ) k sin θ) (+ Doppler over m).
/// The range IDFT (kernel e^(+j2π ni/N), scaled 1/N as the paper) puts it at bin i = r/Δr; the
/// array DFT (kernel e^(−j2π kj/A)) at signed bin s = A (d/λ) sin θ; so positive angles lie right
/// of broadside after fftshift.
pub struct Estimator {
    config: EstimatorConfig,
    n: usize,
    k: usize,
    m: usize,
    n_pad: usize,
    /// Row stride of `work`: n_pad plus one cache line, so the K·M rows (read one bin at a time
    /// by the angle transform) do not all fall in the same cache set when n_pad·16 B is a
    /// multiple of 4 KiB.
    stride: usize,
    a: usize,
    rows: usize,
    search_rows: usize,
    circular_range: bool,
    range_bin_m: f64,
    unambiguous_m: f64,
    spacing_wl: f64,
    ifft_range: Arc<dyn Fft<f64>>,
    fft_angle: Arc<dyn Fft<f64>>,
    fft_doppler: Arc<dyn Fft<f64>>,
    scratch: Vec<Complex64>,
    inv_x: Vec<Complex64>,
    work: AlignedBuf<Complex64>,
    tile: Vec<Complex64>,
    tile2: Vec<Complex64>,
    tile_bins: usize,
    power: Vec<f64>,
    row_max: Vec<f64>,
    doppler_bin: Vec<u16>,
    visible_fft: Vec<bool>,
    visible_shifted: Vec<bool>,
    tw_angle: Vec<Complex64>,
    tw_doppler: Vec<Complex64>,
    det: DetectScratch,
    detections: Vec<RangeAngleDetection>,
    floor: f64,
    /// The super-resolution solver and its method, when `refinement` names one (and K ≥ 2).
    cells: Option<(CellSolver, Subspace)>,
    /// Form of the streaming loops (AVX2 when the CPU has it).
    isa: Isa,
}

impl std::fmt::Debug for Estimator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Estimator")
            .field("config", &self.config)
            .field("subcarriers", &self.n)
            .field("antennas", &self.k)
            .field("symbols", &self.m)
            .field("range_bins", &self.rows)
            .field("angle_bins", &self.a)
            .finish_non_exhaustive()
    }
}

/// Checks the OFDM parameters the estimator uses; fields are named `ofdm.<field>`.
pub fn validate_params(p: &OfdmParams) -> Result<(), InvalidParam> {
    InvalidParam::check_count("ofdm.subcarriers", p.subcarriers, 1, 1 << 24)?;
    InvalidParam::check_count("ofdm.symbols", p.symbols, 1, u16::MAX as usize)?;
    InvalidParam::check_count("ofdm.antennas", p.antennas, 1, 1 << 16)?;
    InvalidParam::check_range(
        "ofdm.carrier_frequency_hz",
        p.carrier_frequency_hz,
        1.0,
        1e13,
    )?;
    InvalidParam::check_range(
        "ofdm.subcarrier_spacing_hz",
        p.subcarrier_spacing_hz,
        1.0,
        1e10,
    )?;
    InvalidParam::check_range(
        "ofdm.antenna_spacing_wavelengths",
        p.antenna_spacing_wavelengths,
        1e-3,
        100.0,
    )?;
    Ok(())
}

fn alloc<T: Clone>(len: usize, value: T) -> Result<Vec<T>, EstimatorError> {
    let mut v = reserve(len)?;
    v.resize(len, value);
    Ok(v)
}

/// An empty vector with room for exactly `len` values, or the allocation error (never aborts).
fn reserve<T>(len: usize) -> Result<Vec<T>, EstimatorError> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| EstimatorError::Allocation {
            bytes: len.saturating_mul(std::mem::size_of::<T>()),
        })?;
    Ok(v)
}

/// Bytes of a transparent huge page (x86_64 and aarch64 Linux with 4 KiB base pages).
const HUGE_PAGE: usize = 2 << 20;

/// Asks Linux to back the whole 2 MiB pages inside `bytes` at `addr` with transparent huge
/// pages (when `/sys/kernel/mm/transparent_hugepage/enabled` is `madvise` or `always`): the
/// large buffers are streamed many rows at a time, and 4 KiB pages cost TLB misses there.
#[allow(unused_variables)]
fn advise_huge_pages(addr: usize, bytes: usize) {
    #[cfg(target_os = "linux")]
    {
        let start = addr.div_ceil(HUGE_PAGE) * HUGE_PAGE;
        let end = addr.saturating_add(bytes) / HUGE_PAGE * HUGE_PAGE;
        if end > start {
            // SAFETY: madvise only changes how pages of this process's own (allocated, not yet
            // touched) memory are backed; the result is ignored (it is a hint).
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
    }
}

/// `alloc` with huge pages advised before the memory is first touched.
fn alloc_huge<T: Clone>(len: usize, value: T) -> Result<Vec<T>, EstimatorError> {
    let mut v = reserve(len)?;
    advise_huge_pages(v.as_ptr() as usize, len * std::mem::size_of::<T>());
    v.resize(len, value);
    Ok(v)
}

/// A buffer of `len` values starting at a huge-page boundary of a larger allocation (when the
/// values take at least one huge page), so all of it can be backed by huge pages.
struct AlignedBuf<T> {
    buf: Vec<T>,
    start: usize,
    len: usize,
}

impl<T: Clone> AlignedBuf<T> {
    fn new(len: usize, value: T) -> Result<Self, EstimatorError> {
        let size = std::mem::size_of::<T>().max(1);
        let slack = if len.saturating_mul(size) >= HUGE_PAGE {
            HUGE_PAGE / size
        } else {
            0
        };
        let buf = alloc_huge(len + slack, value)?;
        let addr = buf.as_ptr() as usize;
        let start = if slack > 0 {
            (addr.div_ceil(HUGE_PAGE) * HUGE_PAGE - addr) / size
        } else {
            0
        };
        Ok(Self { buf, start, len })
    }
}

impl<T> std::ops::Deref for AlignedBuf<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.buf[self.start..self.start + self.len]
    }
}

impl<T> std::ops::DerefMut for AlignedBuf<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.buf[self.start..self.start + self.len]
    }
}

fn twiddles(len: usize) -> Vec<Complex64> {
    (0..len)
        .map(|q| Complex64::from_polar(1.0, -2.0 * PI * q as f64 / len as f64))
        .collect()
}

/// Signed angle bin of an FFT-order column: c for c < A − ⌊A/2⌋, c − A above.
fn signed_fft(col: usize, a: usize) -> isize {
    if col < a - a / 2 {
        col as isize
    } else {
        col as isize - a as isize
    }
}

/// Visibility mask (|sin θ| ≤ 1) of the columns, given each column's signed bin.
fn visibility(a: usize, spacing_wl: f64, signed: impl Fn(usize) -> isize) -> Vec<bool> {
    let limit = a as f64 * spacing_wl * (1.0 + 1e-12);
    (0..a).map(|c| (signed(c) as f64).abs() <= limit).collect()
}

/// Where the complex values of a map come from, for refinement.
enum Values<'a> {
    /// Recomputed from the range-transformed rows (grid path): a K-term (× M-term) DFT.
    Grid {
        work: &'a [Complex64],
        k: usize,
        m: usize,
        stride: usize,
        tw_angle: &'a [Complex64],
        tw_doppler: &'a [Complex64],
        doppler_bin: &'a [u16],
        cols: usize,
    },
    /// Stored (spectrum path).
    Stored {
        values: &'a [Complex64],
        cols: usize,
    },
}

impl Values<'_> {
    /// Complex value at (row, col) — for the grid path at the Doppler bin of cell `peak`.
    fn at(&self, row: usize, col: usize, peak: (usize, usize)) -> Complex64 {
        match *self {
            Values::Grid {
                work,
                k,
                m,
                stride,
                tw_angle,
                tw_doppler,
                doppler_bin,
                cols,
            } => {
                let d = if m > 1 {
                    doppler_bin[peak.0 * cols + peak.1] as usize
                } else {
                    0
                };
                let mut acc = ZERO;
                for kk in 0..k {
                    let wa = tw_angle[(kk * col) % cols];
                    for mm in 0..m {
                        let wd = tw_doppler[(mm * d) % m];
                        acc += work[(kk * m + mm) * stride + row] * wa * wd;
                    }
                }
                acc
            }
            Values::Stored { values, cols } => values[row * cols + col],
        }
    }

    /// The array snapshots of range bin `row` (one per symbol, `k` elements each) into `all`
    /// and their mean into `mean`, scaled so that a unit echo is a unit-modulus steering vector.
    /// A stored map row is turned back into its K elements by the inverse of the (padded,
    /// fftshifted) array DFT: exact when the row holds every angle bin of the echo's response.
    fn snapshots(
        &self,
        row: usize,
        k: usize,
        signed: &dyn Fn(usize) -> isize,
        all: &mut Vec<Complex64>,
        mean: &mut Vec<Complex64>,
    ) {
        all.clear();
        mean.clear();
        match *self {
            Values::Grid {
                work, m, stride, ..
            } => {
                mean.resize(k, ZERO);
                for mm in 0..m {
                    for (kk, x) in mean.iter_mut().enumerate() {
                        let v = work[(kk * m + mm) * stride + row];
                        *x += v;
                        // Each symbol's row carries the 1/M of the mean; undo it per snapshot.
                        all.push(v * m as f64);
                    }
                }
            }
            Values::Stored { values, cols } => {
                let line = &values[row * cols..(row + 1) * cols];
                let a = cols as f64;
                // e^{+j2π q/A} for q = 0..A: the inverse array DFT's kernel, by index.
                let kernel = |q: isize| {
                    Complex64::from_polar(1.0, 2.0 * PI * q.rem_euclid(cols as isize) as f64 / a)
                };
                let steps: Vec<Complex64> = (0..cols).map(|c| kernel(signed(c))).collect();
                let mut turn: Vec<Complex64> = vec![Complex64::new(1.0, 0.0); cols];
                for _ in 0..k {
                    let mut acc = ZERO;
                    for ((v, t), step) in line.iter().zip(turn.iter_mut()).zip(&steps) {
                        acc += v * *t;
                        *t *= step;
                    }
                    mean.push(acc / a);
                }
                all.extend_from_slice(mean);
            }
        }
    }
}

/// What a super-resolved wave's std is made of.
struct WaveBounds {
    /// Elements K and unpadded subcarriers N (the apertures of the bounds).
    k: usize,
    n: usize,
    /// The frame's noise floor (map units).
    floor: f64,
    /// Unpadded range bin (m) and the model floor of the std, as a fraction of the cell's.
    range_cell_m: f64,
    std_fraction: f64,
}

/// What the super-resolution path needs beyond a [`RefineCtx`].
struct Resolve<'a> {
    solver: &'a mut CellSolver,
    method: Subspace,
    bounds: WaveBounds,
    /// A wave is published when its power is at least this (map units): the detector's
    /// threshold over the floor, and the dynamic range under the frame's strongest peak.
    min_power: f64,
    /// Noise power of one element of one snapshot.
    snapshot_noise: f64,
    max_detections: usize,
    /// The transforms' shape and `sidelobe_margin_db`, for blanking range side lobes.
    lobes: Lobes,
    sidelobe_margin_db: Option<f64>,
}

/// Everything refinement needs about one map.
struct RefineCtx<'a> {
    values: Values<'a>,
    rows: usize,
    cols: usize,
    circular_range: bool,
    interpolate: bool,
    /// Unpadded range transform length, or `None` when range is zero-padded.
    range_len: Option<usize>,
    /// Unpadded angle transform length, or `None` when angle is zero-padded.
    angle_len: Option<usize>,
    range_bin_m: f64,
    spacing_wl: f64,
    signed: &'a dyn Fn(usize) -> isize,
    shifted: &'a dyn Fn(usize) -> usize,
}

impl RefineCtx<'_> {
    fn range_offset(&self, pk: &Peak) -> f64 {
        if !self.interpolate {
            return 0.0;
        }
        self.range_offset_of(pk.row, |row| {
            Some(self.values.at(row, pk.col, (pk.row, pk.col)))
        })
    }

    /// The range bin `offset` bins from `i`, wrapping when the map is circular in range.
    fn row_at(&self, i: usize, offset: isize) -> Option<usize> {
        let rows = self.rows as isize;
        let j = i as isize + offset;
        if (0..rows).contains(&j) {
            Some(j as usize)
        } else if self.circular_range && rows > 2 * RANGE_PROFILE_BINS + 1 {
            Some(j.rem_euclid(rows) as usize)
        } else {
            None
        }
    }

    /// The range bins below and above bin `i` (wrapping when the map is circular in range).
    fn neighbours(&self, i: usize) -> (Option<usize>, Option<usize>) {
        let rows = self.rows;
        let wraps = self.circular_range && rows > 2;
        let below = if i > 0 {
            Some(i - 1)
        } else {
            wraps.then(|| rows - 1)
        };
        let above = if i + 1 < rows {
            Some(i + 1)
        } else {
            wraps.then_some(0)
        };
        (below, above)
    }

    /// The sub-bin range offset of a peak in bin `i` from the complex values `at` gives at its
    /// neighbours (`None`: no value there): Candan unpadded, parabolic padded, Rife at an edge.
    fn range_offset_of(&self, i: usize, at: impl Fn(usize) -> Option<Complex64>) -> f64 {
        let (below, above) = self.neighbours(i);
        let Some(x0) = at(i) else {
            return 0.0;
        };
        let below = below.and_then(&at);
        let above = above.and_then(&at);
        let delta = match (below, above, self.range_len) {
            (Some(b), Some(a), Some(len)) => refine::candan(b, x0, a, len),
            (Some(b), Some(a), None) => {
                refine::parabolic_log(b.norm_sqr(), x0.norm_sqr(), a.norm_sqr())
            }
            (None, Some(a), Some(len)) => refine::rife(x0.norm_sqr(), a.norm_sqr(), 1.0, len),
            (Some(b), None, Some(len)) => refine::rife(x0.norm_sqr(), b.norm_sqr(), -1.0, len),
            _ => None,
        };
        delta.unwrap_or(0.0)
    }

    /// Super-resolution: each range bin holding a peak resolved into waves
    /// (`crate::superres`); a bin where no wave passes `min_power` keeps its DFT peaks. Strongest
    /// first, at most `max_detections`.
    fn resolved(&self, peaks: &[Peak], r: Resolve<'_>) -> Vec<RangeAngleDetection> {
        let Resolve {
            solver,
            method,
            bounds,
            min_power,
            snapshot_noise,
            max_detections,
            lobes,
            sidelobe_margin_db,
        } = r;
        let k = bounds.k;
        let mut rows: Vec<usize> = peaks.iter().map(|p| p.row).collect();
        rows.sort_unstable();
        rows.dedup();
        let (mut all, mut mean) = (Vec::new(), Vec::new());
        let mut neighbour = Vec::new();
        let mut out = Vec::new();
        let sine_per_omega = 1.0 / (2.0 * PI * self.spacing_wl);
        let kk = (k as f64).powi(2);
        for row in rows {
            self.values
                .snapshots(row, k, self.signed, &mut all, &mut mean);
            let waves = solver.solve(method, &all, &mean, min_power / kk, snapshot_noise);
            let omegas: Vec<f64> = waves.iter().map(|w| w.omega).collect();
            // Each wave's amplitude in the bins around, for its range offset.
            let fit = superres::WaveFit::new(k, &omegas);
            let profile: Vec<(isize, Vec<Complex64>)> = (-RANGE_PROFILE_BINS..=RANGE_PROFILE_BINS)
                .filter(|&o| o != 0)
                .filter_map(|o| {
                    let other = self.row_at(row, o)?;
                    self.values
                        .snapshots(other, k, self.signed, &mut all, &mut neighbour);
                    Some((o, fit.as_ref()?.amplitudes(&neighbour)?))
                })
                .collect();
            let before = out.len();
            for (idx, wave) in waves.iter().enumerate() {
                let power = wave.amplitude.norm_sqr() * kk;
                let sine = wave.omega * sine_per_omega;
                if power.is_nan() || power < min_power || sine.abs() > 1.0 {
                    continue;
                }
                let at = |o: isize| {
                    if o == 0 {
                        Some(wave.amplitude)
                    } else {
                        profile.iter().find(|(p, _)| *p == o).map(|(_, v)| v[idx])
                    }
                };
                let (below_row, above_row) = self.neighbours(row);
                let start = self.range_offset_of(row, |other| {
                    if other == row {
                        at(0)
                    } else if Some(other) == below_row {
                        at(-1)
                    } else if Some(other) == above_row {
                        at(1)
                    } else {
                        None
                    }
                });
                let offset = match self.range_len {
                    Some(len) => ml_range_offset(&at, start, len),
                    None => start,
                };
                out.push(self.wave_detection(row, row as f64 + offset, sine, power, &bounds));
            }
            if out.len() == before {
                out.extend(
                    peaks
                        .iter()
                        .filter(|p| p.row == row)
                        .map(|p| self.detection(p)),
                );
            }
        }
        out.sort_by(|a, b| b.power_db.total_cmp(&a.power_db));
        if let Some(margin_db) = sidelobe_margin_db {
            out = self.blank_range_sidelobes(out, lobes, margin_db);
        }
        out.truncate(max_detections);
        out
    }

    /// A super-resolved wave found in bin `bin`, at fractional range bin `range_bin`, sin θ =
    /// `sine` (|sine| ≤ 1) and `power` (map units), with its std: the single-tone Cramér–Rao
    /// bound at its SNR over the floor, in quadrature with the model floor (`std_fraction` of the
    /// resolution cell's).
    fn wave_detection(
        &self,
        bin: usize,
        range_bin: f64,
        sine: f64,
        power: f64,
        b: &WaveBounds,
    ) -> RangeAngleDetection {
        let sine_per_omega = 1.0 / (2.0 * PI * self.spacing_wl);
        let sine_cell = 1.0 / (b.k as f64 * self.spacing_wl);
        let angle_rad = sine.asin();
        let snr = power / b.floor;
        let range_crb = superres::crb_std(snr, b.n) * b.n as f64 * b.range_cell_m / (2.0 * PI);
        let sine_crb = superres::crb_std(snr, b.k) * sine_per_omega;
        let model = b.std_fraction / 12f64.sqrt();
        let sine_std = sine_crb.hypot(model * sine_cell);
        RangeAngleDetection {
            range_m: (range_bin * self.range_bin_m).max(0.0),
            angle_rad,
            power_db: 10.0 * power.log10(),
            range_bin: bin,
            angle_bin: nearest_shifted_bin(sine, self.cols, self.spacing_wl),
            std: Some(DetectionStd {
                range_m: range_crb.hypot(model * b.range_cell_m),
                angle_rad: (sine_std / angle_rad.cos().max(0.05)).min(std::f64::consts::FRAC_PI_2),
            }),
        }
    }

    /// NOMP (`crate::nomp`) on the range bins around the peaks: gridless atoms in range and
    /// angle, strongest first.
    fn nomp_detections(
        &self,
        peaks: &[Peak],
        min_power: f64,
        max_detections: usize,
        b: &WaveBounds,
    ) -> Vec<RangeAngleDetection> {
        let mut rows: Vec<usize> = peaks
            .iter()
            .flat_map(|p| {
                p.row.saturating_sub(crate::nomp::PATCH_BINS)
                    ..=(p.row + crate::nomp::PATCH_BINS).min(self.rows - 1)
            })
            .collect();
        rows.sort_unstable();
        rows.dedup();
        let (mut all, mut mean) = (Vec::new(), Vec::new());
        let mut samples = Vec::with_capacity(rows.len() * b.k);
        for &row in &rows {
            self.values
                .snapshots(row, b.k, self.signed, &mut all, &mut mean);
            samples.extend_from_slice(&mean);
        }
        let patch = crate::nomp::Patch {
            rows,
            k: b.k,
            n: b.n,
            samples,
        };
        let sine_per_omega = 1.0 / (2.0 * PI * self.spacing_wl);
        let kk = (b.k as f64).powi(2);
        crate::nomp::nomp(patch, min_power, max_detections)
            .into_iter()
            .filter_map(|atom| {
                let omega = (atom.omega + PI).rem_euclid(2.0 * PI) - PI;
                let sine = omega * sine_per_omega;
                (sine.abs() <= 1.0).then(|| {
                    let bin = (atom.range_bin.round().max(0.0) as usize).min(self.rows - 1);
                    let power = atom.amplitude.norm_sqr() * kk;
                    self.wave_detection(bin, atom.range_bin, sine, power, b)
                })
            })
            .collect()
    }

    /// Drops each wave (strongest first) that a stronger kept one in another range bin can
    /// explain as its range side lobe: the DFT path's blanking (`DetectScratch::detect`), with
    /// the angle distance in bins of sin θ. Within one bin the waves are resolved, not lobes.
    fn blank_range_sidelobes(
        &self,
        sorted: Vec<RangeAngleDetection>,
        lobes: Lobes,
        margin_db: f64,
    ) -> Vec<RangeAngleDetection> {
        let margin = 10f64.powf(margin_db / 10.0);
        let bins_per_sine = self.cols as f64 * self.spacing_wl;
        let mut kept: Vec<RangeAngleDetection> = Vec::with_capacity(sorted.len());
        for q in sorted {
            let blanked = kept.iter().any(|s| {
                if s.range_bin == q.range_bin {
                    return false;
                }
                let dr = crate::detect::circular(q.range_bin, s.range_bin, lobes.range_period);
                let da = ((q.angle_rad.sin() - s.angle_rad.sin()).abs() * bins_per_sine).round();
                let g = crate::detect::envelope(dr, lobes.range_pad, lobes.range_len)
                    * crate::detect::envelope(da as usize, lobes.angle_pad, lobes.angle_len);
                q.power_db <= s.power_db + 10.0 * (g * margin).log10()
            });
            if !blanked {
                kept.push(q);
            }
        }
        kept
    }

    fn angle_offset(&self, pk: &Peak) -> f64 {
        if !self.interpolate || self.cols < 3 {
            return 0.0;
        }
        let c = self.cols;
        let at = |col| self.values.at(pk.row, col, (pk.row, pk.col));
        let (xm, x0, xp) = (at((pk.col + c - 1) % c), at(pk.col), at((pk.col + 1) % c));
        let delta = match self.angle_len {
            Some(len) => refine::candan(xm, x0, xp, len),
            None => refine::parabolic_log(xm.norm_sqr(), x0.norm_sqr(), xp.norm_sqr()),
        };
        delta.unwrap_or(0.0)
    }

    fn detection(&self, pk: &Peak) -> RangeAngleDetection {
        let range_m = ((pk.row as f64 + self.range_offset(pk)) * self.range_bin_m).max(0.0);
        let a = self.cols as f64;
        let s = (self.signed)(pk.col) as f64 + self.angle_offset(pk);
        let s = (s + a / 2.0).rem_euclid(a) - a / 2.0;
        let sin = (s / (a * self.spacing_wl)).clamp(-1.0, 1.0);
        RangeAngleDetection {
            range_m,
            angle_rad: sin.asin(),
            power_db: 10.0 * pk.power.log10(),
            range_bin: pk.row,
            angle_bin: (self.shifted)(pk.col),
            std: None,
        }
    }
}

/// What the refinements need to know of the frame's map.
struct Frame {
    /// Elements K and unpadded subcarriers N.
    k: usize,
    n: usize,
    /// The map's noise floor (map units) and one snapshot element's noise power (the map's
    /// floor is K times the mean snapshot's; a symbol's snapshot carries M times that).
    floor: f64,
    snapshot_noise: f64,
    /// Unpadded range bin (m).
    range_cell_m: f64,
    lobes: Lobes,
    /// Whether the map's rows give back the K elements' samples (else the DFT peaks stand).
    resolvable: bool,
}

/// The detections of `peaks` by the configured refinement, into `out`: NOMP, a subspace method
/// (`cells`), or the DFT peaks themselves (interpolated or not).
fn refined_detections(
    ctx: &RefineCtx<'_>,
    peaks: &[Peak],
    config: &EstimatorConfig,
    cells: Option<&mut (CellSolver, Subspace)>,
    frame: &Frame,
    out: &mut Vec<RangeAngleDetection>,
) {
    let bounds = WaveBounds {
        k: frame.k,
        n: frame.n,
        floor: frame.floor,
        range_cell_m: frame.range_cell_m,
        std_fraction: config.interpolated_std_fraction,
    };
    let min_power = min_wave_power(config, frame.floor, peaks);
    let usable = frame.resolvable && frame.k >= 2;
    if usable && config.refinement == Refinement::Nomp {
        out.extend(ctx.nomp_detections(peaks, min_power, config.max_detections, &bounds));
        return;
    }
    match cells.filter(|_| usable) {
        Some((solver, method)) => {
            let resolve = Resolve {
                solver,
                method: *method,
                bounds,
                min_power,
                snapshot_noise: frame.snapshot_noise,
                max_detections: config.max_detections,
                lobes: frame.lobes,
                sidelobe_margin_db: config.sidelobe_margin_db,
            };
            out.extend(ctx.resolved(peaks, resolve));
        }
        None => out.extend(peaks.iter().map(|pk| ctx.detection(pk))),
    }
}

/// The noise power of one Doppler bin over the floor `DetectScratch::noise_floor` measures on a
/// map whose cells keep the strongest of M Doppler bins: that floor is the median of the maximum
/// of M exponentials over ln 2, and the median of that maximum is −ln(1 − 2^(−1/M)) bins'
/// noise (1 at M = 1; 1/8.5 at M = 256).
fn doppler_floor_correction(m: usize) -> f64 {
    let median_of_max = -(-(0.5f64.powf(1.0 / m.max(1) as f64))).ln_1p();
    std::f64::consts::LN_2 / median_of_max
}

/// The least power (map units) a super-resolved wave needs to be published: the detector's own
/// threshold over the frame's floor (peak picking's `threshold_db`, or CFAR's factor for its full
/// training window at `cfar_pfa` with the floor as the training mean), and `dynamic_range_db`
/// under the frame's strongest peak (`peaks` is sorted strongest first).
fn min_wave_power(config: &EstimatorConfig, floor: f64, peaks: &[Peak]) -> f64 {
    let threshold = match config.detector {
        crate::Detector::PeakPicking => 10f64.powf(config.threshold_db / 10.0),
        crate::Detector::Cfar => {
            crate::detect::cfar_factor(crate::detect::full_training_cells(config), config.cfar_pfa)
        }
    };
    let strongest = peaks.first().map_or(0.0, |p| p.power);
    (floor * threshold).max(strongest * 10f64.powf(-config.dynamic_range_db / 10.0))
}

/// Range bins on each side of a super-resolved wave's bin whose amplitudes place it in range.
const RANGE_PROFILE_BINS: isize = 4;

/// The maximum-likelihood range offset of one wave (in bins, near `start`) from its amplitudes
/// `at(o)` in the bins o = −4 ..= 4 around its own (`None` where the map has none): the δ that
/// maximises |Σ_o at(o) · conj(D_N((o − δ)/N))|² / Σ_o |D_N((o − δ)/N)|², D_N the range kernel
/// of an unpadded N-point transform (`nrslam_ofdm::spectral`). Three-point interpolation
/// (Candan) reaches about 1.6 × the Cramér–Rao bound; this fit of the nine bins, about 1.1 ×
/// (`nrslam accuracy --refine music`).
fn ml_range_offset(at: &dyn Fn(isize) -> Option<Complex64>, start: f64, len: usize) -> f64 {
    let values: Vec<(f64, Complex64)> = (-RANGE_PROFILE_BINS..=RANGE_PROFILE_BINS)
        .filter_map(|o| at(o).map(|v| (o as f64, v)))
        .collect();
    let n = len as f64;
    let fit = |delta: f64| {
        let (mut dot, mut energy) = (ZERO, 0.0);
        for &(o, v) in &values {
            let kernel = nrslam_ofdm::spectral::dirichlet(len, (o - delta) / n);
            dot += v * kernel.conj();
            energy += kernel.norm_sqr();
        }
        if energy > 0.0 {
            -dot.norm_sqr() / energy
        } else {
            0.0
        }
    };
    let (lo, hi) = ((start - 0.3).max(-0.6), (start + 0.3).min(0.6));
    let delta = superres::golden_minimum(fit, 0.5 * (lo + hi), 0.5 * (hi - lo));
    if delta.is_finite() {
        delta
    } else {
        start
    }
}

/// The fftshifted angle bin (broadside A/2) nearest to sin θ = `sine`.
fn nearest_shifted_bin(sine: f64, cols: usize, spacing_wl: f64) -> usize {
    let a = cols as f64;
    let signed = (sine * a * spacing_wl).round();
    ((signed + (cols / 2) as f64).rem_euclid(a) as usize).min(cols - 1)
}

/// The power map [`Estimator::transform`] left, as the detector reads it. A macro rather than a
/// method so that it borrows only these fields, leaving the detector free to be borrowed mutably.
macro_rules! grid_view {
    ($estimator:expr) => {
        MapView {
            power: &$estimator.power,
            row_max: &$estimator.row_max,
            rows: $estimator.rows,
            cols: $estimator.a,
            search_rows: $estimator.search_rows,
            circular_range: $estimator.circular_range,
            visible: &$estimator.visible_fft,
        }
    };
}

impl Estimator {
    /// Plans every FFT and allocates every buffer for frames of `params`' sizes.
    ///
    /// Memory: K·M·N·padding complex cells for the range-transformed rows, plus rows × A power
    /// cells (rows = the range window). Errors name the bad field; nothing panics.
    pub fn new(params: &OfdmParams, config: EstimatorConfig) -> Result<Self, EstimatorError> {
        validate_params(params)?;
        config.validate()?;
        let (n, k, m) = (params.subcarriers, params.antennas, params.symbols);
        let n_pad = n * config.range_padding();
        let a = k * config.zero_padding_angle;
        let stride = n_pad + ROW_PAD;
        let work_cells = k
            .checked_mul(m)
            .and_then(|x| x.checked_mul(stride))
            .filter(|&c| c <= MAX_WORK_CELLS)
            .ok_or_else(|| {
                InvalidParam::new(
                    "ofdm.subcarriers",
                    format!(
                        "K·M·N·padding = {k}·{m}·{n}·{} is too large",
                        config.range_padding()
                    ),
                    format!("at most {MAX_WORK_CELLS} cells"),
                )
            })?;
        let range_bin_m = params.range_bin_m() / config.range_padding() as f64;
        let (rows, search_rows) = match config.max_range_m {
            None => (n_pad, n_pad),
            Some(r) => {
                let last = (r / range_bin_m).floor().min(n_pad as f64) as usize;
                ((last + 2).min(n_pad), (last + 1).min(n_pad))
            }
        };
        if config.detector == crate::Detector::Cfar {
            let span = 2 * (config.cfar_guard_angle + config.cfar_train_angle) + 1;
            if span > a {
                return Err(InvalidParam::new(
                    "cfar_train_angle",
                    format!("the CFAR window spans {span} angle bins but there are {a}"),
                    format!("2·(cfar_guard_angle + cfar_train_angle) + 1 <= {a}"),
                )
                .into());
            }
        }
        let cells = match config.refinement {
            Refinement::Music { subarray } | Refinement::Esprit { subarray } if k >= 2 => {
                if subarray > k {
                    return Err(InvalidParam::new(
                        "refinement.subarray",
                        format!("{subarray} elements, but the array has {k}"),
                        format!("0 (auto) or 2 to {k}"),
                    )
                    .into());
                }
                let method = if matches!(config.refinement, Refinement::Music { .. }) {
                    Subspace::Music
                } else {
                    Subspace::Esprit
                };
                let l = if subarray == 0 {
                    superres::default_subarray(k)
                } else {
                    subarray
                };
                Some((CellSolver::new(k, l), method))
            }
            _ => None,
        };
        let mut planner = FftPlanner::<f64>::new();
        let ifft_range = planner.plan_fft_inverse(n_pad);
        let fft_angle = planner.plan_fft_forward(a);
        let fft_doppler = planner.plan_fft_forward(m);
        let scratch_len = ifft_range
            .get_inplace_scratch_len()
            .max(fft_angle.get_inplace_scratch_len())
            .max(fft_doppler.get_inplace_scratch_len());
        let tile_bins = (TILE_CELLS / (a * m)).max(1).min(rows);
        let spacing_wl = params.antenna_spacing_wavelengths;
        Ok(Self {
            n,
            k,
            m,
            n_pad,
            stride,
            a,
            rows,
            search_rows,
            circular_range: rows == n_pad,
            range_bin_m,
            unambiguous_m: params.unambiguous_range_m(),
            spacing_wl,
            ifft_range,
            fft_angle,
            fft_doppler,
            scratch: alloc(scratch_len, ZERO)?,
            inv_x: alloc(m * n, ZERO)?,
            work: AlignedBuf::new(work_cells, ZERO)?,
            tile: alloc(tile_bins * m * a, ZERO)?,
            tile2: alloc(if m > 1 { tile_bins * m * a } else { 0 }, ZERO)?,
            tile_bins,
            power: alloc_huge(rows * a, 0.0)?,
            row_max: alloc(rows, 0.0)?,
            doppler_bin: alloc(if m > 1 { rows * a } else { 0 }, 0u16)?,
            visible_fft: visibility(a, spacing_wl, |c| signed_fft(c, a)),
            visible_shifted: visibility(a, spacing_wl, |c| c as isize - (a / 2) as isize),
            tw_angle: twiddles(a),
            tw_doppler: twiddles(m),
            det: DetectScratch::default(),
            detections: Vec::new(),
            floor: 0.0,
            cells,
            isa: Isa::detect(),
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &EstimatorConfig {
        &self.config
    }

    /// Range bins of the grid path's map (the range window plus one neighbour bin).
    pub fn range_bins(&self) -> usize {
        self.rows
    }

    /// Angle bins A = K · zero_padding_angle.
    pub fn angle_bins(&self) -> usize {
        self.a
    }

    /// Size of one (padded) range bin (m).
    pub fn range_bin_m(&self) -> f64 {
        self.range_bin_m
    }

    /// Noise floor (mean noise power per cell, map units) used for the last frame.
    pub fn noise_floor(&self) -> f64 {
        self.floor
    }

    /// One `waveform` frame to detections, strongest first.
    ///
    /// Y/X element-wise (cells with X = 0 or subnormal are skipped: S = 0 there, the range
    /// kernel loses those terms), IDFT over subcarriers (1/N), DFT over the array, and for M > 1
    /// a DFT over symbols of which each (range, angle) cell keeps its strongest Doppler bin;
    /// then detection and refinement.
    ///
    /// # Errors
    /// Grid shape not the estimator's; a NaN or infinite sample (named with its index); every
    /// X zero; overflow.
    pub fn process_grid(
        &mut self,
        grid: &ResourceGrid,
    ) -> Result<Vec<RangeAngleDetection>, EstimatorError> {
        self.transform(grid, None)?;
        self.detect_grid();
        Ok(self.detections.clone())
    }

    /// The processed complex range × angle map of one `waveform` frame (what `spectral`
    /// synthesises directly): the range window's bins, angles fftshifted (broadside at A/2),
    /// for M > 1 each cell's strongest Doppler bin; `noise_power` is the estimated floor.
    pub fn range_angle_map(
        &mut self,
        grid: &ResourceGrid,
    ) -> Result<RangeAngleSpectrum, EstimatorError> {
        let mut values = alloc(self.rows * self.a, ZERO)?;
        self.transform(grid, Some(&mut values))?;
        self.floor = self.det.noise_floor(&grid_view!(self));
        Ok(RangeAngleSpectrum {
            range_bins: self.rows,
            angle_bins: self.a,
            range_bin_m: self.range_bin_m,
            values,
            noise_power: self.floor,
        })
    }

    /// Detection (and refinement) only, on a map synthesised by the `spectral` front end.
    ///
    /// `range_bin_m` is read as the spacing of this spectrum's bins; the range dimension is
    /// circular when the spectrum spans the whole unambiguous range; the noise floor is the
    /// spectrum's `noise_power` when positive, else estimated from the map. Zero padding in each
    /// dimension is inferred from the bin sizes (range: Δr / range_bin_m; angle: angle_bins / K).
    ///
    /// # Errors
    /// Inconsistent shape, a non-positive bin size, a NaN or infinite value, a CFAR window wider
    /// than the angle bins.
    pub fn process_spectrum(
        &mut self,
        spectrum: &RangeAngleSpectrum,
    ) -> Result<Vec<RangeAngleDetection>, EstimatorError> {
        let (rows, a) = (spectrum.range_bins, spectrum.angle_bins);
        let bad = |s: String| Err(EstimatorError::SpectrumShape(s));
        if rows == 0 || a == 0 || rows.checked_mul(a) != Some(spectrum.values.len()) {
            return bad(format!(
                "{} values for {rows} range × {a} angle bins (both must be ≥ 1)",
                spectrum.values.len()
            ));
        }
        if !(spectrum.range_bin_m.is_finite() && spectrum.range_bin_m > 0.0) {
            return bad(format!(
                "range_bin_m = {} (must be > 0)",
                spectrum.range_bin_m
            ));
        }
        if !(spectrum.noise_power.is_finite() && spectrum.noise_power >= 0.0) {
            return bad(format!(
                "noise_power = {} (must be ≥ 0)",
                spectrum.noise_power
            ));
        }
        if self.config.detector == crate::Detector::Cfar {
            let span = 2 * (self.config.cfar_guard_angle + self.config.cfar_train_angle) + 1;
            if span > a {
                return bad(format!(
                    "the CFAR window spans {span} angle bins, the map {a}"
                ));
            }
        }
        self.power.clear();
        self.row_max.clear();
        for (row, line) in spectrum.values.chunks_exact(a).enumerate() {
            let mut mx = 0.0f64;
            let mut ok = true;
            for v in line {
                let p = v.norm_sqr();
                ok &= v.re.is_finite() & v.im.is_finite();
                mx = mx.max(p);
                self.power.push(p);
            }
            if !ok {
                let col = line
                    .iter()
                    .position(|v| !(v.re.is_finite() && v.im.is_finite()))
                    .unwrap_or(0);
                return Err(EstimatorError::NonFinite {
                    input: "spectrum",
                    index: row * a + col,
                    value: line[col].to_string(),
                });
            }
            if !mx.is_finite() {
                return Err(EstimatorError::Overflow("|spectrum value|²"));
            }
            self.row_max.push(mx);
        }
        let search_rows = match self.config.max_range_m {
            None => rows,
            Some(r) => ((r / spectrum.range_bin_m).floor().min(rows as f64) as usize + 1).min(rows),
        };
        let span_m = rows as f64 * spectrum.range_bin_m;
        let circular = (span_m - self.unambiguous_m).abs() <= 1e-6 * self.unambiguous_m;
        let range_pad =
            (self.range_bin_m * self.config.range_padding() as f64 / spectrum.range_bin_m).round();
        let visible = if a == self.a {
            std::mem::take(&mut self.visible_shifted)
        } else {
            visibility(a, self.spacing_wl, |c| c as isize - (a / 2) as isize)
        };
        let view = MapView {
            power: &self.power,
            row_max: &self.row_max,
            rows,
            cols: a,
            search_rows,
            circular_range: circular,
            visible: &visible,
        };
        self.floor = if spectrum.noise_power > 0.0 {
            spectrum.noise_power
        } else {
            self.det.noise_floor(&view)
        };
        let lobes = Lobes {
            range_period: (self.unambiguous_m / spectrum.range_bin_m).round() as usize,
            range_len: self.n,
            range_pad: range_pad.max(1.0),
            angle_len: self.k,
            angle_pad: (a as f64 / self.k as f64).max(1.0),
        };
        let peaks = self.det.detect(&view, &self.config, self.floor, lobes);
        let half = a / 2;
        let ctx = RefineCtx {
            values: Values::Stored {
                values: &spectrum.values,
                cols: a,
            },
            rows,
            cols: a,
            circular_range: circular,
            interpolate: self.config.refinement == Refinement::Interpolation,
            range_len: (range_pad == 1.0).then_some(self.n),
            angle_len: (a == self.k).then_some(a),
            range_bin_m: spectrum.range_bin_m,
            spacing_wl: self.spacing_wl,
            signed: &|c| c as isize - half as isize,
            shifted: &|c| c,
        };
        self.detections.clear();
        let frame = Frame {
            k: self.k,
            n: self.n,
            floor: self.floor,
            snapshot_noise: self.floor / self.k as f64,
            range_cell_m: spectrum.range_bin_m * range_pad.max(1.0),
            lobes,
            // A row of fewer angle bins than elements cannot give back the K samples.
            resolvable: a >= self.k,
        };
        let cells = self.cells.as_mut();
        refined_detections(
            &ctx,
            peaks,
            &self.config,
            cells,
            &frame,
            &mut self.detections,
        );
        if a == self.a {
            self.visible_shifted = visible;
        }
        Ok(self.detections.clone())
    }

    fn detect_grid(&mut self) {
        self.floor = self.det.noise_floor(&grid_view!(self));
        let view = grid_view!(self);
        let lobes = Lobes {
            range_period: self.n_pad,
            range_len: self.n,
            range_pad: self.config.range_padding() as f64,
            angle_len: self.k,
            angle_pad: self.config.zero_padding_angle as f64,
        };
        let peaks = self.det.detect(&view, &self.config, self.floor, lobes);
        let a = self.a;
        let ctx = RefineCtx {
            values: Values::Grid {
                work: &self.work,
                k: self.k,
                m: self.m,
                stride: self.stride,
                tw_angle: &self.tw_angle,
                tw_doppler: &self.tw_doppler,
                doppler_bin: &self.doppler_bin,
                cols: a,
            },
            rows: self.rows,
            cols: a,
            circular_range: self.circular_range,
            interpolate: self.config.refinement == Refinement::Interpolation,
            range_len: (self.n_pad == self.n).then_some(self.n),
            angle_len: (a == self.k).then_some(a),
            range_bin_m: self.range_bin_m,
            spacing_wl: self.spacing_wl,
            signed: &|c| signed_fft(c, a),
            shifted: &|c| (c + a / 2) % a,
        };
        self.detections.clear();
        let frame = Frame {
            k: self.k,
            n: self.n,
            floor: self.floor,
            snapshot_noise: self.floor * doppler_floor_correction(self.m) * self.m as f64
                / self.k as f64,
            range_cell_m: self.range_bin_m * self.config.range_padding() as f64,
            lobes,
            resolvable: true,
        };
        let cells = self.cells.as_mut();
        refined_detections(
            &ctx,
            peaks,
            &self.config,
            cells,
            &frame,
            &mut self.detections,
        );
    }

    fn check_grid(&self, grid: &ResourceGrid) -> Result<(), EstimatorError> {
        let checks = [
            ("antennas", self.k, grid.antennas),
            ("symbols", self.m, grid.symbols),
            ("subcarriers", self.n, grid.subcarriers),
            (
                "received.len()",
                self.k * self.m * self.n,
                grid.received.len(),
            ),
            ("transmitted.len()", self.m * self.n, grid.transmitted.len()),
        ];
        for (what, expected, found) in checks {
            if expected != found {
                return Err(EstimatorError::GridShape {
                    what,
                    expected,
                    found,
                });
            }
        }
        Ok(())
    }

    /// Y/X, range IDFT, angle (and Doppler) DFT into `power`/`row_max` (and `map` when given,
    /// fftshifted).
    fn transform(
        &mut self,
        grid: &ResourceGrid,
        mut map: Option<&mut Vec<Complex64>>,
    ) -> Result<(), EstimatorError> {
        self.check_grid(grid)?;
        // `process_spectrum` reuses these buffers at the spectrum's own size; restore the grid
        // path's (no reallocation once both sizes have been seen).
        self.power.resize(self.rows * self.a, 0.0);
        self.row_max.resize(self.rows, 0.0);
        let Self {
            n,
            k,
            m,
            n_pad,
            stride,
            a,
            rows,
            ifft_range,
            fft_angle,
            fft_doppler,
            scratch,
            inv_x,
            work,
            tile,
            tile2,
            tile_bins,
            power,
            row_max,
            doppler_bin,
            isa,
            ..
        } = self;
        let isa = *isa;
        let (n, k, m, n_pad, stride, a, rows) = (*n, *k, *m, *n_pad, *stride, *a, *rows);

        // 1/X scaled by the paper's 1/N (and 1/M, so that a static echo's zero-Doppler bin equals
        // the mean over symbols of `nrslam_ofdm::reference`); zero (skip) where X is zero or
        // subnormal.
        let scale = 1.0 / (n as f64 * m as f64);
        let usable = kernels::reciprocals(isa, &grid.transmitted, inv_x, scale).map_err(|i| {
            EstimatorError::NonFinite {
                input: "transmitted",
                index: i,
                value: grid.transmitted[i].to_string(),
            }
        })?;
        if usable == 0 {
            return Err(EstimatorError::NoReference);
        }

        // S = Y/X into the work rows, then the range IDFT of each row while it is in cache.
        for (r, (row, y)) in work
            .chunks_exact_mut(stride)
            .zip(grid.received.chunks_exact(n))
            .enumerate()
        {
            // No per-sample finiteness test here: a NaN or infinity reaches every output of
            // the row's IDFT and from there every cell's power, where it is caught below.
            let inv = &inv_x[(r % m) * n..(r % m + 1) * n];
            kernels::mul_row(isa, &mut row[..n], y, inv);
            let row = &mut row[..n_pad];
            row[n..].fill(ZERO);
            ifft_range.process_with_scratch(row, scratch);
        }

        // Angle (and Doppler) transforms, a tile of range bins at a time, gathered from the
        // antenna-major rows into bin-major order.
        let mut i0 = 0;
        while i0 < rows {
            let bb = (*tile_bins).min(rows - i0);
            let t = &mut tile[..bb * m * a];
            if a > k {
                t.fill(ZERO);
            }
            kernels::gather(isa, work, t, i0, bb, k, m, a, stride);
            fft_angle.process_with_scratch(t, scratch);
            if m == 1 {
                kernels::norm_sqr_max_rows(
                    isa,
                    t,
                    a,
                    &mut power[i0 * a..(i0 + bb) * a],
                    &mut row_max[i0..i0 + bb],
                );
                if let Some(map) = map.as_deref_mut() {
                    store_shifted(t, &mut map[i0 * a..(i0 + bb) * a], a);
                }
            } else {
                let t2 = &mut tile2[..bb * m * a];
                fft_doppler_keep_strongest(
                    t,
                    t2,
                    fft_doppler.as_ref(),
                    scratch,
                    TileShape { i0, bb, m, a },
                    DopplerOut {
                        power,
                        doppler_bin,
                        row_max,
                        map: map.as_deref_mut(),
                    },
                );
            }
            i0 += bb;
        }
        if row_max.iter().any(|p| !p.is_finite()) {
            return Err(non_finite_power(grid));
        }
        Ok(())
    }
}

/// Why a cell's power is not finite: a non-finite received sample, named, or else an overflow.
fn non_finite_power(grid: &ResourceGrid) -> EstimatorError {
    let bad = grid
        .received
        .iter()
        .position(|v| !(v.re.is_finite() && v.im.is_finite()));
    match bad {
        Some(i) => EstimatorError::NonFinite {
            input: "received",
            index: i,
            value: grid.received[i].to_string(),
        },
        None => EstimatorError::Overflow("Y/X or the range-angle transforms"),
    }
}

/// Copies the angle spectra of `tile` (one line of `a` bins per range bin) into `map` with the
/// angle axis fftshifted.
fn store_shifted(tile: &[Complex64], map: &mut [Complex64], a: usize) {
    let half = a / 2;
    for (line, dst) in tile.chunks_exact(a).zip(map.chunks_exact_mut(a)) {
        for (c, v) in line.iter().enumerate() {
            dst[(c + half) % a] = *v;
        }
    }
}

/// A tile of `bb` range bins from bin `i0`, `m` symbols and `a` angle bins.
struct TileShape {
    i0: usize,
    bb: usize,
    m: usize,
    a: usize,
}

/// Where the Doppler transform's strongest bins go.
struct DopplerOut<'o> {
    power: &'o mut [f64],
    doppler_bin: &'o mut [u16],
    row_max: &'o mut [f64],
    map: Option<&'o mut Vec<Complex64>>,
}

/// The Doppler DFT of each (range, angle) cell of the angle-transformed tile `t` (bin-major,
/// symbols inner after the transposition into `t2`), keeping each cell's strongest Doppler bin:
/// its power, its index, the row maxima (NaN when a row's total is not finite) and, with a map,
/// the value itself at the fftshifted angle.
fn fft_doppler_keep_strongest(
    t: &[Complex64],
    t2: &mut [Complex64],
    fft_doppler: &dyn Fft<f64>,
    scratch: &mut [Complex64],
    TileShape { i0, bb, m, a }: TileShape,
    out: DopplerOut<'_>,
) {
    let DopplerOut {
        power,
        doppler_bin,
        row_max,
        mut map,
    } = out;
    let half = a / 2;
    for b in 0..bb {
        for mm in 0..m {
            for c in 0..a {
                t2[(b * a + c) * m + mm] = t[(b * m + mm) * a + c];
            }
        }
    }
    fft_doppler.process_with_scratch(t2, scratch);
    for b in 0..bb {
        let mut mx = 0.0f64;
        let mut sum = 0.0f64;
        for c in 0..a {
            let chunk = &t2[(b * a + c) * m..(b * a + c + 1) * m];
            let (mut best, mut best_p) = (0usize, -1.0f64);
            for (d, v) in chunk.iter().enumerate() {
                let p = v.norm_sqr();
                sum += p;
                if p > best_p {
                    best = d;
                    best_p = p;
                }
            }
            let cell = (i0 + b) * a + c;
            power[cell] = best_p;
            doppler_bin[cell] = best as u16;
            mx = mx.max(best_p);
            if let Some(map) = map.as_deref_mut() {
                map[(i0 + b) * a + (c + half) % a] = chunk[best];
            }
        }
        row_max[i0 + b] = if sum.is_finite() { mx } else { f64::NAN };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aligned_buffers_start_on_a_huge_page_and_hold_len_values() {
        for len in [
            0,
            1,
            1000,
            HUGE_PAGE / 16,
            HUGE_PAGE / 16 + 3,
            3 * HUGE_PAGE / 16,
        ] {
            let mut b = AlignedBuf::new(len, ZERO).unwrap();
            assert_eq!(b.len(), len);
            assert!(b.iter().all(|v| *v == ZERO));
            if len * 16 >= HUGE_PAGE {
                assert_eq!(b.as_ptr() as usize % HUGE_PAGE, 0);
            }
            if let Some(last) = b.last_mut() {
                *last = Complex64::new(1.0, 2.0);
            }
            assert_eq!(
                b.iter().filter(|v| **v != ZERO).count(),
                usize::from(len > 0)
            );
        }
    }
}
