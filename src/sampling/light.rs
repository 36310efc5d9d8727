//! Light (emitter) sampling (math.md §11, "Light (emitter) sampling"): a luminance distribution
//! over world directions, piecewise constant on a lat-long grid of cells.
//!
//! The grid is the map's own (math.md §10, "Cells"): `rows` bands of equal polar angle
//! `θ ∈ [rπ/rows, (r + 1)π/rows)` (θ from the map's `+y`), each cut into `cols` cells of equal
//! azimuth `ψ = atan2(d.x, −d.z)` from `psi_start`. Cell `(r, c)` has a luminance `Y ≥ 0` and the
//! solid angle `ΔΩ = Δψ (cos θ_r − cos θ_{r+1})` (the `sin θ` Jacobian, integrated exactly). A
//! direction is drawn by choosing a cell with probability `Y ΔΩ / Σ Y ΔΩ` (a cumulative table
//! over rows, then one per row over its cells) and a point uniform in `(cos θ, ψ)` inside it, so
//! its solid-angle density is
//!
//! `p_L(d) = Y_cell(d) / Σ_cells Y ΔΩ`,
//!
//! zero where `Y = 0`, and [`LightDistribution::pdf`] gives it exactly at any direction (MIS needs
//! `p_L` of directions another technique drew). The primary sample `u ∈ [0, 1)²` is warped
//! measure-preservingly: `u₁` picks the row and, rescaled to the row's share, places `cos θ`;
//! `u₂` likewise the cell and `ψ` — so stratified or Sobol `u` stay stratified on the sphere.
//!
//! **MIS compensation** (Karlík, Šik, Vévoda, Skřivan & Křivánek, "MIS compensation: optimizing
//! sampling techniques in multiple importance sampling", SIGGRAPH Asia 2019): the density
//! `∝ max(0, Y − Ȳ)`, `Ȳ = Σ Y ΔΩ / 4π` the map's mean, leaves the smooth part of the light to
//! the BSDF technique. It is built only when `Ȳ − min Y > 0.01 Ȳ` (else the compensated density
//! is almost empty: the map is constant); it misses the light below the mean, so it is only
//! unbiased together with a technique that covers it (MIS).
//!
//! Built once per map (cached on [`crate::render::env::EnvMap`]): `O(rows · cols)` time and
//! memory; a 1024×512 map builds in milliseconds (`cargo bench --bench light`,
//! docs/guide/performance.md).

use crate::util::geometry::Vec3;
use std::f64::consts::{PI, TAU};

/// Rec. 709 luminance of linear RGB, the weights the light distribution uses.
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// `Ȳ − min Y` must exceed this share of `Ȳ` for a compensated density (Karlík et al. 2019).
pub const COMPENSATION_THRESHOLD: f64 = 0.01;

/// The luminance of linear RGB.
#[inline]
pub fn luminance(rgb: [f64; 3]) -> f64 {
    LUMINANCE[0] * rgb[0] + LUMINANCE[1] * rgb[1] + LUMINANCE[2] * rgb[2]
}

/// The lat-long grid the distribution is constant on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Bands of equal polar angle, from `θ = 0` (the map's `+y`) to `π`.
    pub rows: usize,
    /// Cells of equal azimuth per band.
    pub cols: usize,
    /// The azimuth `ψ = atan2(d.x, −d.z)` where cell 0 starts; the cells span `2π` from it.
    pub psi_start: f64,
}

/// The map direction at polar angle `θ` (from `+y`) and azimuth `ψ`:
/// `(sin θ sin ψ, cos θ, −sin θ cos ψ)`, so that `atan2(d.x, −d.z) = ψ`.
#[inline]
pub fn direction(cos_theta: f64, psi: f64) -> Vec3 {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (s, c) = psi.sin_cos();
    Vec3::new(sin_theta * s, cos_theta, -sin_theta * c)
}

/// One sampling table: a density per cell and the cumulative tables that draw from it.
#[derive(Clone, Debug)]
struct Table {
    /// The unnormalised density of each cell (per unit solid angle), row-major.
    density: Vec<f64>,
    /// `Σ density · ΔΩ`.
    total: f64,
    /// `rows + 1` cumulative probabilities of the bands, from 0 to exactly 1.
    row_cdf: Vec<f64>,
    /// `rows × (cols + 1)` cumulative probabilities of the cells within each band (a band of no
    /// mass keeps zeros: it is never chosen).
    col_cdf: Vec<f64>,
    /// Guide tables (Chen & Asau 1974) of `row_cdf` (`rows` entries) and of each band's
    /// `col_cdf` (`cols` per band): [`Guide::invert`].
    row_guide: Guide,
    col_guides: Vec<Guide>,
}

/// A guide table of a cumulative table `cdf` of `n` intervals: entry `k` is the interval
/// holding `k/n`, so that inverting `u` starts at entry `⌊u n⌋` and walks a step or two
/// instead of a binary search through the whole table (a band's table of a 1024-wide map is
/// 8 KiB; each light sample would otherwise touch ten of its cache lines). The result is the
/// binary search's exactly ([`invert`]).
#[derive(Clone, Debug)]
struct Guide(Vec<u32>);

impl Guide {
    fn new(cdf: &[f64]) -> Self {
        let n = cdf.len() - 1;
        Guide(
            (0..n)
                .map(|k| cdf[1..].partition_point(|&c| c <= k as f64 / n as f64).min(n - 1) as u32)
                .collect(),
        )
    }

    /// [`invert`] of `u` on `cdf` (the table this guide was built from), starting at the guide.
    #[inline]
    fn invert(&self, cdf: &[f64], u: f64) -> (usize, f64) {
        let n = cdf.len() - 1;
        let k = ((u * n as f64) as usize).min(n - 1);
        let mut i = self.0[k] as usize;
        // The first i with cdf[i + 1] > u: back while the interval starts above u (rounding of
        // k/n), then forward past intervals that end at or below it.
        while i > 0 && cdf[i] > u {
            i -= 1;
        }
        while i < n - 1 && cdf[i + 1] <= u {
            i += 1;
        }
        rescale(cdf, i, u)
    }
}

impl Table {
    fn build(grid: &Grid, cos_edges: &[f64], density: Vec<f64>) -> Self {
        let (rows, cols) = (grid.rows, grid.cols);
        let dpsi = TAU / cols as f64;
        let mut row_mass = Vec::with_capacity(rows);
        let mut col_cdf = Vec::with_capacity(rows * (cols + 1));
        for r in 0..rows {
            let band = dpsi * (cos_edges[r] - cos_edges[r + 1]);
            let start = col_cdf.len();
            let mut sum = 0.0;
            col_cdf.push(0.0);
            for c in 0..cols {
                sum += density[r * cols + c];
                col_cdf.push(sum);
            }
            if sum > 0.0 {
                for v in &mut col_cdf[start..] {
                    *v /= sum;
                }
                col_cdf[start + cols] = 1.0;
            }
            row_mass.push(sum * band);
        }
        let total: f64 = row_mass.iter().sum();
        let mut row_cdf = Vec::with_capacity(rows + 1);
        let mut acc = 0.0;
        row_cdf.push(0.0);
        for m in &row_mass {
            acc += m;
            row_cdf.push(if total > 0.0 { acc / total } else { 0.0 });
        }
        if total > 0.0 {
            row_cdf[rows] = 1.0;
        }
        let row_guide = Guide::new(&row_cdf);
        let col_guides = col_cdf.chunks(cols + 1).map(Guide::new).collect();
        Table {
            density,
            total,
            row_cdf,
            col_cdf,
            row_guide,
            col_guides,
        }
    }
}

/// The index `i` of the interval `[cdf[i], cdf[i + 1])` holding `u ∈ [0, 1)` (intervals of no
/// mass are skipped), and `u` rescaled to `[0, 1)` inside it.
#[cfg(test)]
#[inline]
fn invert(cdf: &[f64], u: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    // The first i with cdf[i + 1] > u.
    let i = cdf[1..].partition_point(|&c| c <= u).min(n - 1);
    rescale(cdf, i, u)
}

/// Interval `i` of `cdf` and `u` rescaled to `[0, 1)` inside it.
#[inline]
fn rescale(cdf: &[f64], i: usize, u: f64) -> (usize, f64) {
    let (lo, hi) = (cdf[i], cdf[i + 1]);
    let t = if hi > lo { (u - lo) / (hi - lo) } else { 0.5 };
    (i, t.clamp(0.0, 1.0 - f64::EPSILON / 2.0))
}

/// A light's luminance distribution over world directions (see the module docs).
#[derive(Clone, Debug)]
pub struct LightDistribution {
    grid: Grid,
    /// `cos θ` at the `rows + 1` band edges.
    cos_edges: Vec<f64>,
    /// The plain density `∝ Y`.
    plain: Table,
    /// The compensated density `∝ max(0, Y − Ȳ)`, when `Ȳ − min Y > 1% Ȳ`.
    compensated: Option<Table>,
    /// `Ȳ` and `min Y` over the cells.
    mean: f64,
    min: f64,
}

impl LightDistribution {
    /// The distribution of cell luminances `y[r · cols + c]` (each finite, ≥ 0) on `grid`.
    ///
    /// # Panics
    /// On an empty grid, a length that is not `rows · cols`, or a negative or non-finite value.
    pub fn new(grid: Grid, y: Vec<f64>) -> Self {
        assert!(grid.rows >= 1 && grid.cols >= 1 && y.len() == grid.rows * grid.cols);
        assert!(
            y.iter().all(|v| v.is_finite() && *v >= 0.0),
            "luminances are finite and >= 0"
        );
        let cos_edges: Vec<f64> = (0..=grid.rows)
            .map(|r| match r {
                0 => 1.0,
                r if r == grid.rows => -1.0,
                r => (r as f64 * PI / grid.rows as f64).cos(),
            })
            .collect();
        let min = y.iter().copied().fold(f64::INFINITY, f64::min);
        let plain = Table::build(&grid, &cos_edges, y);
        let mean = plain.total / (4.0 * PI);
        let compensated = (mean - min > COMPENSATION_THRESHOLD * mean).then(|| {
            let d = plain.density.iter().map(|&v| (v - mean).max(0.0)).collect();
            Table::build(&grid, &cos_edges, d)
        });
        LightDistribution {
            grid,
            cos_edges,
            plain,
            compensated,
            mean,
            min,
        }
    }

    /// Tabulates `y(cos θ, ψ)` at the centre of every cell of `grid` (in `cos θ` and `ψ`): for a
    /// light given as a function that is positive everywhere (the procedural sky), where any
    /// positive density is exact as long as [`LightDistribution::pdf`] is the one drawn from.
    pub fn tabulate(grid: Grid, y: impl Fn(&Vec3) -> f64) -> Self {
        let dpsi = TAU / grid.cols as f64;
        let mut values = Vec::with_capacity(grid.rows * grid.cols);
        for r in 0..grid.rows {
            let (a, b) = (
                (r as f64 * PI / grid.rows as f64).cos(),
                ((r + 1) as f64 * PI / grid.rows as f64).cos(),
            );
            for c in 0..grid.cols {
                let d = direction(0.5 * (a + b), grid.psi_start + (c as f64 + 0.5) * dpsi);
                values.push(y(&d));
            }
        }
        Self::new(grid, values)
    }

    /// The uniform distribution over the sphere, `p = 1/(4π)`: a constant (white) light.
    pub fn uniform() -> Self {
        Self::new(
            Grid {
                rows: 1,
                cols: 1,
                psi_start: -PI,
            },
            vec![1.0],
        )
    }

    /// The grid.
    pub fn grid(&self) -> Grid {
        self.grid
    }

    /// `Ȳ`, the mean luminance over the sphere (`Σ Y ΔΩ / 4π`).
    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// The smallest cell luminance.
    pub fn min(&self) -> f64 {
        self.min
    }

    /// Whether a compensated density exists: `Ȳ − min Y > 1% Ȳ` (otherwise the light is constant,
    /// to that share, and compensation has nothing to remove).
    pub fn has_compensation(&self) -> bool {
        self.compensated.is_some()
    }

    /// Whether the light has any power (`Σ Y ΔΩ > 0`); a black light cannot be sampled.
    pub fn is_black(&self) -> bool {
        self.plain.total <= 0.0
    }

    fn table(&self, compensated: bool) -> &Table {
        if compensated {
            self.compensated
                .as_ref()
                .expect("compensation asked of a light without it (check has_compensation)")
        } else {
            &self.plain
        }
    }

    /// The cell holding world direction `d` (unit).
    #[inline]
    fn cell_of(&self, d: &Vec3) -> usize {
        let (rows, cols) = (self.grid.rows, self.grid.cols);
        let theta = d.y.clamp(-1.0, 1.0).acos();
        let r = ((theta / PI * rows as f64) as usize).min(rows - 1);
        let psi = d.x.atan2(-d.z);
        let t = ((psi - self.grid.psi_start) / TAU).rem_euclid(1.0);
        let c = ((t * cols as f64) as usize).min(cols - 1);
        r * cols + c
    }

    /// The solid-angle density `p_L(d)` of world direction `d` (unit): `Y_cell(d) / Σ Y ΔΩ`, of
    /// the compensated density when `compensated`.
    ///
    /// # Panics
    /// If the light is black or `compensated` is asked of a light without it.
    #[inline]
    pub fn pdf(&self, d: &Vec3, compensated: bool) -> f64 {
        let t = self.table(compensated);
        assert!(t.total > 0.0, "a black light has no density");
        t.density[self.cell_of(d)] / t.total
    }

    /// The world direction for the primary sample `u ∈ [0, 1)²` and its density.
    ///
    /// # Panics
    /// As [`LightDistribution::pdf`].
    pub fn sample(&self, u: [f64; 2], compensated: bool) -> (Vec3, f64) {
        let t = self.table(compensated);
        assert!(t.total > 0.0, "a black light cannot be sampled");
        let cols = self.grid.cols;
        let (r, v1) = t.row_guide.invert(&t.row_cdf, u[0]);
        let (c, v2) = t.col_guides[r].invert(&t.col_cdf[r * (cols + 1)..(r + 1) * (cols + 1)], u[1]);
        let (a, b) = (self.cos_edges[r], self.cos_edges[r + 1]);
        let cos_theta = a + v1 * (b - a);
        let psi = self.grid.psi_start + (c as f64 + v2) * TAU / cols as f64;
        (direction(cos_theta, psi), t.density[r * cols + c] / t.total)
    }

    /// The probability that a sample lands in cell `(r, c)` (for the χ² test of the histogram).
    pub fn cell_probability(&self, row: usize, col: usize, compensated: bool) -> f64 {
        let t = self.table(compensated);
        let band = TAU / self.grid.cols as f64 * (self.cos_edges[row] - self.cos_edges[row + 1]);
        t.density[row * self.grid.cols + col] * band / t.total
    }

    /// The cell `(row, col)` holding world direction `d`.
    pub fn cell(&self, d: &Vec3) -> (usize, usize) {
        let k = self.cell_of(d);
        (k / self.grid.cols, k % self.grid.cols)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The guide tables invert exactly as the binary search does, at random `u`, at the
    /// guide's own breakpoints `k/n` and next to every cumulative value, on a map with empty
    /// bands and cells.
    #[test]
    fn guide_tables_invert_as_the_binary_search() {
        let grid = Grid {
            rows: 7,
            cols: 9,
            psi_start: -PI,
        };
        let y: Vec<f64> = (0..63)
            .map(|i| {
                if i % 5 == 0 || (18..27).contains(&i) {
                    0.0
                } else {
                    (i % 7) as f64
                }
            })
            .collect();
        let d = LightDistribution::new(grid, y);
        let t = &d.plain;
        let mut us: Vec<f64> = (0..2000).map(|i| (i as f64 * 0.618_034).fract()).collect();
        for &c in t.row_cdf.iter().chain(&t.col_cdf) {
            us.extend([c, c - 1e-17, c + 1e-16, (c - f64::EPSILON).max(0.0)]);
        }
        us.extend((0..9).map(|k| k as f64 / 9.0));
        us.extend((0..7).map(|k| k as f64 / 7.0));
        for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
            assert_eq!(
                t.row_guide.invert(&t.row_cdf, u),
                invert(&t.row_cdf, u),
                "row {u}"
            );
            for r in 0..7 {
                let cdf = &t.col_cdf[r * 10..(r + 1) * 10];
                assert_eq!(t.col_guides[r].invert(cdf, u), invert(cdf, u), "band {r} {u}");
            }
        }
    }
    use crate::util::rng::stream;
    use rand::RngExt;

    fn varied(rows: usize, cols: usize) -> LightDistribution {
        let y = (0..rows * cols)
            .map(|k| match k % 7 {
                0 => 0.0,
                3 => 40.0,
                m => m as f64 * 0.3,
            })
            .collect();
        LightDistribution::new(
            Grid {
                rows,
                cols,
                psi_start: 0.3,
            },
            y,
        )
    }

    /// `∫ p_L dω = 1` to 1e-9 for the plain and compensated densities: the pdf at any direction,
    /// integrated by a midpoint rule in `(cos θ, ψ)` on a grid that refines the cells (exact for a
    /// piecewise-constant density whose cells it refines, up to the cells cut by the grid's
    /// `θ` bands, which are aligned here).
    #[test]
    fn the_pdf_integrates_to_one() {
        let (rows, cols) = (6, 10);
        let light = varied(rows, cols);
        for compensated in [false, true] {
            // Integrate cell by cell in (cos θ, ψ) with 3×3 midpoints per cell.
            let mut sum = 0.0;
            for r in 0..rows {
                let (a, b) = (light.cos_edges[r], light.cos_edges[r + 1]);
                for c in 0..cols {
                    for i in 0..3 {
                        for j in 0..3 {
                            let mu = a + (b - a) * (i as f64 + 0.5) / 3.0;
                            let psi = 0.3 + (c as f64 + (j as f64 + 0.5) / 3.0) * TAU / cols as f64;
                            let w = (a - b) / 3.0 * TAU / cols as f64 / 3.0;
                            sum += w * light.pdf(&direction(mu, psi), compensated);
                        }
                    }
                }
            }
            assert!((sum - 1.0).abs() < 1e-9, "compensated {compensated}: {sum}");
            let cells: f64 = (0..rows)
                .flat_map(|r| (0..cols).map(move |c| (r, c)))
                .map(|(r, c)| light.cell_probability(r, c, compensated))
                .sum();
            assert!((cells - 1.0).abs() < 1e-12);
        }
        assert!((LightDistribution::uniform().pdf(&Vec3::x(), false) - 1.0 / (4.0 * PI)).abs() < 1e-15);
    }

    /// The density `sample` returns is `pdf` at the sampled direction, samples are unit vectors,
    /// and cells of no luminance are never drawn.
    #[test]
    fn samples_carry_their_pdf_and_avoid_black_cells() {
        let light = varied(5, 8);
        let mut rng = stream(3, &[]);
        for compensated in [false, true] {
            for _ in 0..20_000 {
                let u = [rng.random::<f64>(), rng.random::<f64>()];
                let (d, p) = light.sample(u, compensated);
                assert!((d.norm() - 1.0).abs() < 1e-12);
                assert!(p > 0.0);
                let q = light.pdf(&d, compensated);
                assert!((p - q).abs() <= 1e-12 * p, "{p} vs {q} at {d:?}");
            }
        }
    }

    /// χ² test of the histogram of cells drawn against the cell probabilities: 200 000 samples
    /// on 40 cells (the empty ones excluded), the statistic below the 0.999 quantile of χ² with
    /// the degrees of freedom (about `k + 3.1√(2k)` for `k` dof); fixed seed.
    #[test]
    fn chi_square_of_the_cell_histogram() {
        let (rows, cols) = (5, 8);
        let light = varied(rows, cols);
        let n = 200_000;
        for compensated in [false, true] {
            let mut rng = stream(4, &[compensated as u64]);
            let mut counts = vec![0usize; rows * cols];
            for _ in 0..n {
                let (d, _) = light.sample([rng.random(), rng.random()], compensated);
                let (r, c) = light.cell(&d);
                counts[r * cols + c] += 1;
            }
            let mut chi2 = 0.0;
            let mut dof = 0usize;
            for r in 0..rows {
                for c in 0..cols {
                    let e = n as f64 * light.cell_probability(r, c, compensated);
                    let o = counts[r * cols + c] as f64;
                    if e == 0.0 {
                        assert_eq!(o, 0.0, "an empty cell was drawn");
                        continue;
                    }
                    chi2 += (o - e) * (o - e) / e;
                    dof += 1;
                }
            }
            let k = (dof - 1) as f64;
            let bound = k + 3.1 * (2.0 * k).sqrt() + 2.0;
            assert!(
                chi2 < bound,
                "compensated {compensated}: χ² = {chi2} with {k} dof"
            );
        }
    }

    /// The warp keeps a stratified `u` stratified: `u₁` in `[0, ½)` lands in the bands holding the
    /// first half of the mass.
    #[test]
    fn the_warp_is_monotone_in_u1() {
        let light = varied(6, 4);
        let mut last = 1.0;
        for i in 0..1000 {
            let (d, _) = light.sample([(i as f64 + 0.5) / 1000.0, 0.37], false);
            assert!(d.y <= last + 1e-15, "cos θ grows with u₁");
            last = d.y;
        }
    }

    /// A constant light has no compensated density; a light with a bright cell does, and it is
    /// zero on the cells at or below the mean.
    #[test]
    fn compensation_only_where_the_light_varies() {
        let grid = Grid {
            rows: 4,
            cols: 4,
            psi_start: 0.0,
        };
        let flat = LightDistribution::new(grid, vec![2.0; 16]);
        assert!(!flat.has_compensation());
        assert!((flat.mean() - 2.0).abs() < 1e-12);
        let mut y = vec![1.0; 16];
        y[5] = 100.0;
        let bright = LightDistribution::new(grid, y);
        assert!(bright.has_compensation());
        assert_eq!(bright.cell_probability(0, 0, true), 0.0);
        assert!((bright.cell_probability(1, 1, true) - 1.0).abs() < 1e-12);
    }
}
