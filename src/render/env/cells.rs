//! A lat-long map as a simple function of the map's own angles (math.md §10, "Cells"): each
//! *profile row* is the radiance along a circle of constant polar angle `θ` as a function of the
//! azimuth `ψ = atan2(d.x, −d.z)`, piecewise linear (constant or bilinear lookups) on equal
//! cells, with prefix sums of `∫ L·{1, sin ψ, cos ψ} dψ` over whole cells, so that the integral
//! of `L(ψ)·(A sin ψ + B + C cos ψ)` over any interval costs two partial cells and one
//! difference of prefix sums.

use std::f64::consts::{PI, TAU};

/// Components of the prefix sums and of [`CellTable::integral`]: `∫L`, `∫L sin ψ`, `∫L cos ψ`.
pub type Moments = [[f64; 3]; 3];

/// An azimuth with its sine and cosine, computed once for every row that uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Azimuth {
    pub psi: f64,
    pub sin: f64,
    pub cos: f64,
}

impl Azimuth {
    #[inline]
    pub fn new(psi: f64) -> Self {
        let (sin, cos) = psi.sin_cos();
        Azimuth { psi, sin, cos }
    }
}

/// The profile rows of one map under one lookup.
#[derive(Clone, Debug)]
pub struct CellTable {
    /// Profile rows.
    rows: usize,
    /// Cells per row, equal in `ψ`, the first starting at `start`; together they span `2π`.
    cells: usize,
    start: f64,
    width: f64,
    /// How the polar angle selects and mixes profile rows.
    rows_in_theta: RowsInTheta,
    /// `L = a₀ + a₁ (ψ − ψ_i)` on cell `i` of each row, row-major; `a₁` is empty for constant
    /// cells.
    a0: Vec<[f64; 3]>,
    a1: Vec<[f64; 3]>,
    /// `rows × (cells + 1)` prefix sums of the moments over whole cells.
    prefix: Vec<Moments>,
    /// The `cells + 1` knots with their sines and cosines.
    knots: Vec<Azimuth>,
    /// Whether every texel is ≥ 0 in every channel (then so is every profile, and `∫L` bounds
    /// `∫|L|`), and each row's largest `|L|` over its cells and channels (the bound otherwise).
    nonnegative: bool,
    row_max: Vec<f64>,
    /// Each row's [`CellTable::magnitude`] over the whole circle.
    row_total: Vec<f64>,
}

/// How `θ ∈ [0, π]` maps to profile rows.
#[derive(Clone, Copy, Debug, PartialEq)]
enum RowsInTheta {
    /// Row `⌊θ(H − 1)/π⌋` (at most `H − 2`), weight 1: the thesis lookup's cells.
    Nearest,
    /// Rows `r₀ = ⌊r⌋` (at most `H − 2`) and `r₀ + 1` with weights `1 − f`, `f`, where
    /// `r = θ(H − 1)/π`, `f = r − r₀`: Mitsuba's bilinear lookup.
    Linear,
}

impl CellTable {
    /// The thesis lookup (`u = (1 + ψ/π)/2`, texel `(⌊v(H − 1)⌋, ⌊u(W − 1)⌋)`): constant on the
    /// `(H − 1) × (W − 1)` cells `ψ ∈ [−π + 2πi/(W − 1), −π + 2π(i + 1)/(W − 1))`, profile row
    /// `j` holding texel row `j`. Needs `W ≥ 2`, `H ≥ 2`; `texel(row, col)` gives linear RGB.
    pub fn constant(width: usize, height: usize, texel: impl Fn(usize, usize) -> [f32; 3]) -> Self {
        assert!(width >= 1 && height >= 2);
        // A one-column map is one cell all round (its only column is column 0 everywhere).
        let cells = (width - 1).max(1);
        let a0 = (0..height - 1)
            .flat_map(|j| (0..cells).map(move |i| (j, i)))
            .map(|(j, i)| texel(j, i).map(f64::from))
            .collect();
        Self::build(height - 1, cells, -PI, RowsInTheta::Nearest, a0, Vec::new())
    }

    /// Mitsuba's lookup (`c = uW − ½`, `u = frac(ψ/2π)`, bilinear between texel centres):
    /// profile row `r` is texel row `r`, linear in `ψ` between the centres
    /// `ψ_i = 2π(i + ½)/W`, cell `W − 1` wrapping from the last centre to the first.
    pub fn bilinear(width: usize, height: usize, texel: impl Fn(usize, usize) -> [f32; 3]) -> Self {
        assert!(width >= 1 && height >= 2);
        let cells = width;
        let step = TAU / width as f64;
        let mut a0 = Vec::with_capacity(height * cells);
        let mut a1 = Vec::with_capacity(height * cells);
        for r in 0..height {
            for i in 0..cells {
                let here = texel(r, i).map(f64::from);
                let next = texel(r, (i + 1) % width).map(f64::from);
                a0.push(here);
                a1.push([0, 1, 2].map(|c| (next[c] - here[c]) / step));
            }
        }
        Self::build(height, cells, PI / width as f64, RowsInTheta::Linear, a0, a1)
    }

    fn build(
        rows: usize,
        cells: usize,
        start: f64,
        rows_in_theta: RowsInTheta,
        a0: Vec<[f64; 3]>,
        a1: Vec<[f64; 3]>,
    ) -> Self {
        let mut table = CellTable {
            rows,
            cells,
            start,
            width: TAU / cells as f64,
            rows_in_theta,
            a0,
            a1,
            prefix: Vec::with_capacity(rows * (cells + 1)),
            knots: Vec::new(),
            nonnegative: true,
            row_max: Vec::new(),
            row_total: Vec::new(),
        };
        // Both lookups' texels are the a₀ (the bilinear profile runs between two of them).
        table.nonnegative = table.a0.iter().flatten().all(|&v| v >= 0.0);
        table.row_max = table
            .a0
            .chunks(cells)
            .map(|row| row.iter().flatten().fold(0.0, |m: f64, v| m.max(v.abs())))
            .collect();
        table.knots = (0..=cells).map(|i| Azimuth::new(table.knot(i))).collect();
        for row in 0..rows {
            let mut sum: Moments = [[0.0; 3]; 3];
            table.prefix.push(sum);
            for i in 0..cells {
                let m = table.partial(row, i, &table.knots[i], &table.knots[i + 1]);
                for (s, m) in sum.iter_mut().zip(m) {
                    for c in 0..3 {
                        s[c] += m[c];
                    }
                }
                table.prefix.push(sum);
            }
        }
        let (first, last) = (table.knots[0], table.knots[cells]);
        table.row_total = (0..rows).map(|row| table.magnitude(row, &first, &last)).collect();
        table
    }

    /// The azimuth where cell `i` starts (`i = cells` is the end of the last).
    #[inline]
    pub fn knot(&self, i: usize) -> f64 {
        self.start + i as f64 * self.width
    }

    /// The first azimuth of the table's `2π` span; every interval given to
    /// [`CellTable::integral`] lies in `[start, start + 2π]`.
    pub fn start(&self) -> f64 {
        self.start
    }

    /// The profile rows and their weights at polar angle `θ`: `(row, weight)` pairs.
    #[inline]
    pub fn rows_at(&self, theta: f64) -> [(usize, f64); 2] {
        match self.rows_in_theta {
            RowsInTheta::Nearest => {
                let j = ((theta / PI * self.rows as f64).floor().max(0.0) as usize).min(self.rows - 1);
                [(j, 1.0), (j, 0.0)]
            }
            RowsInTheta::Linear => {
                let r = theta / PI * (self.rows - 1) as f64;
                let r0 = (r.floor().max(0.0) as usize).min(self.rows - 2);
                let f = r - r0 as f64;
                [(r0, 1.0 - f), (r0 + 1, f)]
            }
        }
    }

    /// The cell boundaries in azimuth, each with its sine and cosine (the first and the last
    /// are one meridian).
    pub fn knots(&self) -> &[Azimuth] {
        &self.knots
    }

    /// The knots strictly between `a` and `b` (in either order), for splitting a polar-angle
    /// piece where an arc's end crosses a cell boundary.
    pub fn knots_between(&self, a: f64, b: f64) -> impl Iterator<Item = f64> + '_ {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        let first = self.cell_of(lo) + 1;
        (first..self.cells)
            .map(|i| self.knot(i))
            .take_while(move |&k| k < hi)
            .filter(move |&k| k > lo)
    }

    /// The cell holding `ψ` (clamped to the span).
    #[inline]
    pub fn cell_of(&self, psi: f64) -> usize {
        (((psi - self.start) / self.width).floor().max(0.0) as usize).min(self.cells - 1)
    }

    /// `∫_x^y L·{1, sin ψ, cos ψ} dψ` inside cell `i` of `row`, from the antiderivatives with
    /// `t = ψ − ψ_i`: `a₀ψ + a₁t²/2`, `−a₀ cos ψ + a₁(sin ψ − t cos ψ)`,
    /// `a₀ sin ψ + a₁(t sin ψ + cos ψ)`.
    #[inline]
    fn partial(&self, row: usize, i: usize, x: &Azimuth, y: &Azimuth) -> Moments {
        let k = row * self.cells + i;
        let a0 = self.a0[k];
        let (sx, cx, sy, cy) = (x.sin, x.cos, y.sin, y.cos);
        let (x, y) = (x.psi, y.psi);
        let d1 = y - x;
        let ds = cx - cy;
        let dc = sy - sx;
        let mut m = [[0.0; 3]; 3];
        for c in 0..3 {
            m[0][c] = a0[c] * d1;
            m[1][c] = a0[c] * ds;
            m[2][c] = a0[c] * dc;
        }
        if let Some(a1) = self.a1.get(k) {
            let knot = self.knot(i);
            let (tx, ty) = (x - knot, y - knot);
            let l1 = 0.5 * (ty * ty - tx * tx);
            let ls = (sy - ty * cy) - (sx - tx * cx);
            let lc = (ty * sy + cy) - (tx * sx + cx);
            for c in 0..3 {
                m[0][c] += a1[c] * l1;
                m[1][c] += a1[c] * ls;
                m[2][c] += a1[c] * lc;
            }
        }
        m
    }

    /// `L_row(ψ)` per channel, for `start ≤ ψ ≤ start + 2π` (the profile the moments integrate;
    /// for the quadrature of a non-linear weight, [`crate::render::texel::lobe`]).
    #[inline]
    pub fn value(&self, row: usize, psi: f64) -> [f64; 3] {
        let i = self.cell_of(psi);
        let k = row * self.cells + i;
        match self.a1.get(k) {
            Some(a1) => {
                let t = psi - self.knot(i);
                [0, 1, 2].map(|c| self.a0[k][c] + a1[c] * t)
            }
            None => self.a0[k],
        }
    }

    /// Whether the profiles have slopes (the bilinear lookup): only then does
    /// [`CellTable::linear`] use its `first` moment.
    pub fn has_slopes(&self) -> bool {
        !self.a1.is_empty()
    }

    /// `∫ L_row(ψ) w(ψ) dψ` over a part of cell `i` from the weight's moments there,
    /// `zeroth = ∫ w` and `first = ∫ (ψ − ψ_i) w` (`ψ_i` = [`CellTable::knot`]`(i)`): `a₀·zeroth +
    /// a₁·first`, since `L = a₀ + a₁ (ψ − ψ_i)` on the cell.
    #[inline]
    pub fn linear(&self, row: usize, i: usize, zeroth: f64, first: f64) -> [f64; 3] {
        let k = row * self.cells + i;
        let a0 = self.a0[k];
        match self.a1.get(k) {
            Some(a1) => [0, 1, 2].map(|c| a0[c] * zeroth + a1[c] * first),
            None => a0.map(|v| v * zeroth),
        }
    }

    /// An upper bound of `max_channel ∫_a^b |L_row(ψ)| dψ` (`a ≤ b` in the span): the prefix sums'
    /// `∫L` when no texel is negative, else the row's largest `|L|` times `b − a`. What an error
    /// bound `|∫ L (w − w̃)| ≤ max|w − w̃| · ∫|L|` multiplies.
    pub fn magnitude(&self, row: usize, a: &Azimuth, b: &Azimuth) -> f64 {
        if self.nonnegative {
            self.integral(row, a, b)[0]
                .iter()
                .fold(0.0, |m: f64, &v| m.max(v))
        } else {
            self.row_max[row] * (b.psi - a.psi)
        }
    }

    /// Profile rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// A scale of the rounding of [`CellTable::integral`]`(row, a, b)` (`a ≤ b` in the span), in
    /// units of `ε_mach` per moment: the prefix sums it subtracts have run up to
    /// [`CellTable::magnitude`] from the span's start to the end of `b`'s cell, and each of
    /// the two partial cells evaluates antiderivatives of size `|a₀| (π + 2)` and, bilinear,
    /// `2 |a₁| (1 + cell width)` at both ends (the largest channel). A difference is off by a
    /// few ulps of these, not of itself: one texel of 3·10¹¹ in a row makes every interval
    /// past it uncertain by 10⁻⁵ absolute.
    pub fn rounding_scale(&self, row: usize, a: &Azimuth, b: &Azimuth) -> f64 {
        let (ia, ib) = (self.cell_of(a.psi), self.cell_of(b.psi));
        let prefix = if self.nonnegative {
            self.prefix[row * (self.cells + 1) + ib + 1][0]
                .iter()
                .fold(0.0, |m: f64, &v| m.max(v))
        } else {
            self.row_max[row] * (self.knot(ib + 1) - self.start)
        };
        let partial = |i: usize| {
            let k = row * self.cells + i;
            let largest = |v: &[f64; 3]| v.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
            let slope = self
                .a1
                .get(k)
                .map_or(0.0, |a1| 2.0 * largest(a1) * (1.0 + self.width));
            largest(&self.a0[k]) * (PI + 2.0) + slope
        };
        prefix + partial(ia) + partial(ib)
    }

    /// [`CellTable::magnitude`] over the whole circle: a bound on every prefix sum of the row,
    /// so a few ulps of it bound the rounding of any [`CellTable::integral`] in the row.
    pub fn row_magnitude(&self, row: usize) -> f64 {
        self.row_total[row]
    }

    /// `∫_a^b L_row(ψ)·{1, sin ψ, cos ψ} dψ` per channel, for `start ≤ a ≤ b ≤ start + 2π`.
    pub fn integral(&self, row: usize, a: &Azimuth, b: &Azimuth) -> Moments {
        let (ia, ib) = (self.cell_of(a.psi), self.cell_of(b.psi));
        if ia == ib {
            return self.partial(row, ia, a, b);
        }
        let mut m = self.partial(row, ia, a, &self.knots[ia + 1]);
        let last = self.partial(row, ib, &self.knots[ib], b);
        let base = row * (self.cells + 1);
        let (lo, hi) = (&self.prefix[base + ia + 1], &self.prefix[base + ib]);
        for k in 0..3 {
            for c in 0..3 {
                m[k][c] += (hi[k][c] - lo[k][c]) + last[k][c];
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::quadrature::GaussLegendre;

    /// Interval integrals against Gauss–Legendre on each cell (the profiles are polynomials of
    /// degree ≤ 1 times sin/cos on a cell: 20 nodes are exact to rounding), for both lookups,
    /// intervals inside one cell, across many and the whole span.
    #[test]
    fn interval_moments_match_quadrature_cell_by_cell() {
        let (w, h) = (7usize, 4usize);
        let texel = |r: usize, c: usize| [(1 + r * w + c) as f32, (c * c) as f32, ((r + 2 * c) % 5) as f32];
        let gl = GaussLegendre::new(20);
        for table in [CellTable::constant(w, h, texel), CellTable::bilinear(w, h, texel)] {
            let profile = |row: usize, psi: f64| -> [f64; 3] {
                let i = table.cell_of(psi);
                let k = row * table.cells + i;
                let t = psi - table.knot(i);
                let slope = table.a1.get(k).copied().unwrap_or([0.0; 3]);
                [0, 1, 2].map(|c| table.a0[k][c] + slope[c] * t)
            };
            let s = table.start();
            for (a, b) in [
                (s + 0.1, s + 0.2),
                (s + 0.05, s + 5.9),
                (s, s + TAU),
                (s + 3.0, s + 3.0),
            ] {
                for row in [0, table.rows - 1] {
                    let got = table.integral(row, &Azimuth::new(a), &Azimuth::new(b));
                    // Reference: per cell piece, Gauss–Legendre.
                    let mut cuts = vec![a, b];
                    cuts.extend(
                        (1..table.cells)
                            .map(|i| table.knot(i))
                            .filter(|k| *k > a && *k < b),
                    );
                    cuts.sort_by(f64::total_cmp);
                    #[allow(clippy::needless_range_loop)] // k and c index the quadrature too
                    for k in 0..3 {
                        for c in 0..3 {
                            let expected: f64 = cuts
                                .windows(2)
                                .map(|p| {
                                    gl.integrate(p[0], p[1], |psi| {
                                        profile(row, psi)[c] * [1.0, psi.sin(), psi.cos()][k]
                                    })
                                })
                                .sum();
                            assert!(
                                (got[k][c] - expected).abs() < 1e-12 * (1.0 + expected.abs()),
                                "[{a}, {b}] row {row} moment {k} channel {c}: {} vs {expected}",
                                got[k][c]
                            );
                        }
                    }
                }
            }
        }
    }

    /// Polar angles select rows as the lookups do: the thesis's `⌊v(H − 1)⌋` (at most `H − 2`
    /// inside the cells), Mitsuba's two neighbouring rows with linear weights.
    #[test]
    fn rows_in_theta_pick_and_mix_rows_like_the_lookups() {
        let t = CellTable::constant(5, 4, |_, _| [1.0; 3]);
        assert_eq!(t.rows_at(0.0)[0], (0, 1.0));
        assert_eq!(t.rows_at(PI * 0.5)[0].0, 1); // ⌊1.5⌋
        assert_eq!(t.rows_at(PI)[0].0, 2); // clamped to H − 2
        let b = CellTable::bilinear(5, 4, |_, _| [1.0; 3]);
        let [(r0, w0), (r1, w1)] = b.rows_at(PI * 0.5);
        assert_eq!((r0, r1), (1, 2));
        assert!((w0 - 0.5).abs() < 1e-15 && (w1 - 0.5).abs() < 1e-15);
        let [(r0, w0), (r1, w1)] = b.rows_at(PI);
        assert_eq!((r0, r1, w0, w1), (2, 3, 0.0, 1.0));
    }
}
