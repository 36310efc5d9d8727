//! BMC on a ring design in `O(J³ M)` instead of `O(N³)` (Karvonen & Särkkä, "Fully symmetric
//! kernel quadrature", SIAM J. Sci. Comput. 2018).
//!
//! **The structure.** On a ring set ([`crate::sampling::rings`]) point `(a, m)` has height
//! `z_a`, `s_a = √(1 − z_a²)` and azimuth `φ_m = 2π (m + u)/M`, the same on every ring. The
//! kernel depends on the squared distance only,
//!
//! `‖x_{a,m} − x_{b,m'}‖² = (s_a − s_b)² + (z_a − z_b)² + 4 s_a s_b sin²(π (m' − m)/M)`,
//!
//! so `Q_{(a,m),(b,m')} = c_ab(m' − m mod M)` with `c_ab(d) = k(x_{a,0}, x_{b,d}) + σ_n² [a = b, d = 0]`
//! (evaluated from coordinates for `d ≤ M/2` and mirrored):
//! every `M × M` block of `Q` is circulant, and `c_ab(d) = c_ab(M − d) = c_ba(d)`.
//!
//! **Block-diagonalisation.** The Fourier vectors `e_f(m) = e^{2πi f m/M}` diagonalise every
//! circulant block: `Q (v ⊗ e_f) = (B_f v) ⊗ e_f` with the `J × J` blocks
//!
//! `(B_f)_ab = Σ_{d=0}^{M−1} c_ab(d) e^{2πi f d/M} = Σ_d c_ab(d) cos(2π f d/M)`,
//!
//! real and symmetric because `c_ab` is even in `d`, positive definite because they are `Q` in
//! a unitary basis, and `B_f = B_{M−f}`. So `Q` is `M` independent `J × J` SPD systems, one per
//! azimuthal frequency, of which `⌊M/2⌋ + 1` are distinct: `Q x = b` is solved by transforming
//! each ring's `b` over `m` (`b̂_a(f) = Σ_m b_a(m) e^{−2πi f m/M}`), solving
//! `B_f x̂(f) = b̂(f)` for each `f` by Cholesky, and transforming back
//! (`x_a(m) = (1/M) Σ_f x̂_a(f) e^{2πi f m/M}`); `(Q⁻¹)_{(a,m),(a,m)} = (1/M) Σ_f (B_f⁻¹)_aa`.
//!
//! **The weights.** The kernel means `z_i` depend on the height only, so `z` is constant on each
//! ring: `z = z_ring ⊗ 1 = z_ring ⊗ e_0`, and `w = Q⁻¹ z` is constant on each ring too,
//! `w_{a,m} = v_a` with the `J × J` system
//!
//! `B_0 v = z_ring`, `(B_0)_ab = Σ_{m'} k(x_{a,0}, x_{b,m'}) + σ_n² [a = b]`
//!
//! (row `(a, 0)` of `Q w = z` with the sum over ring `b`'s circulant row). The same holds for
//! `u = Q⁻¹ 1` (Bayes–Sard) and gives `zᵀ Q⁻¹ z = M Σ_a z_a v_a`. A general right-hand side
//! (`Q⁻¹Y` for the `ml` amplitude, `diag(Q⁻¹)` for `loo`) needs every block.
//!
//! **Cost.** `J(J+1)/2 · (M/2 + 1)` kernel evaluations, `J(J+1)/2` transforms of length `M`
//! (an `O(M log M)` FFT when `M` is a power of two, a direct `O(M²)` sum otherwise),
//! `⌊M/2⌋ + 1` Cholesky factorisations of `J × J` blocks: `O(N J²)` flops and `O(N J)`
//! memory, against `O(N³)` and `8 N²` bytes dense.

use super::{FactorInfo, NotPositiveDefinite, condition_estimate, jitter_ladder};
use crate::bq::kernel::{Kernel, PointsSoa};
use crate::sampling::rings::RingLayout;
use crate::util::geometry::Vec3;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Mat, Par};

/// Largest ring set BMC accepts: its spectra and block factors take about `6 N J` bytes
/// (100 MB at `N = 65536`, `J = 256`), and the time grows like `N^2` (`N J²` flops).
pub const MAX_RING_POINTS: usize = 1 << 16;

/// A discrete Fourier transform of length `M`, unnormalised: radix-2 FFT for powers of two, the
/// direct sum otherwise.
#[derive(Clone, Debug)]
struct Dft {
    len: usize,
    /// `cos(2πk/M)`, `sin(2πk/M)` for `k < M`.
    cos: Vec<f64>,
    sin: Vec<f64>,
}

impl Dft {
    fn new(len: usize) -> Self {
        let angle = |k: usize| std::f64::consts::TAU * k as f64 / len as f64;
        Dft {
            len,
            cos: (0..len).map(|k| angle(k).cos()).collect(),
            sin: (0..len).map(|k| angle(k).sin()).collect(),
        }
    }

    /// In place: `X(f) = Σ_m x(m) e^{∓2πi f m/M}` (`−` forward, `+` inverse), no `1/M`.
    fn transform(&self, re: &mut [f64], im: &mut [f64], inverse: bool, scratch: &mut Vec<f64>) {
        let n = self.len;
        let sign = if inverse { 1.0 } else { -1.0 };
        if n.is_power_of_two() {
            // Iterative radix-2 decimation in time: bit-reversal, then butterflies.
            let bits = n.trailing_zeros();
            for i in 0..n {
                let j = if bits == 0 {
                    0
                } else {
                    i.reverse_bits() >> (usize::BITS - bits)
                };
                if j > i {
                    re.swap(i, j);
                    im.swap(i, j);
                }
            }
            let mut len = 2;
            while len <= n {
                let (half, step) = (len / 2, n / len);
                for start in (0..n).step_by(len) {
                    for k in 0..half {
                        let (wr, wi) = (self.cos[k * step], sign * self.sin[k * step]);
                        let (i, j) = (start + k, start + k + half);
                        let xr = re[j] * wr - im[j] * wi;
                        let xi = re[j] * wi + im[j] * wr;
                        re[j] = re[i] - xr;
                        im[j] = im[i] - xi;
                        re[i] += xr;
                        im[i] += xi;
                    }
                }
                len *= 2;
            }
        } else {
            scratch.clear();
            scratch.resize(2 * n, 0.0);
            for f in 0..n {
                let (mut sr, mut si) = (0.0, 0.0);
                // k = f·m mod M, stepped rather than divided (a division per term cost more
                // than the sum's arithmetic).
                let mut k = 0;
                for m in 0..n {
                    let (c, s) = (self.cos[k], sign * self.sin[k]);
                    sr += re[m] * c - im[m] * s;
                    si += re[m] * s + im[m] * c;
                    k += f;
                    if k >= n {
                        k -= n;
                    }
                }
                scratch[f] = sr;
                scratch[n + f] = si;
            }
            re.copy_from_slice(&scratch[..n]);
            im.copy_from_slice(&scratch[n..]);
        }
    }
}

/// `Q` of a ring set as its frequency blocks' Cholesky factors (see the module documentation).
#[derive(Clone, Debug)]
pub struct RingFactor {
    layout: RingLayout,
    /// `L_f` with `L_f L_fᵀ = B_f + jitter·I`, for `f = 0 ..= M/2` (lower triangles).
    factors: Vec<Mat<f64>>,
    dft: Dft,
    info: FactorInfo,
}

impl RingFactor {
    /// Builds and factors the blocks of `Q = K + σ_n² I` for `points` laid out as `layout`
    /// (ring by ring, as [`crate::sampling::rings::sample_set`] draws them), climbing the same
    /// jitter ladder as [`crate::bq::factor::SpdWorkspace::factor_with`]: jitter `·I` on `Q` is
    /// jitter on every block.
    pub fn new(
        points: &[Vec3],
        layout: RingLayout,
        kernel: &Kernel,
        noise: f64,
    ) -> Result<Self, NotPositiveDefinite> {
        let RingLayout { rings, per_ring } = layout;
        let n = rings * per_ring;
        assert_eq!(points.len(), n, "one point per ring position");
        let z: Vec<f64> = (0..rings).map(|a| points[a * per_ring].z).collect();
        let s: Vec<f64> = z.iter().map(|z| (1.0 - z * z).max(0.0).sqrt()).collect();
        // Ring b's points at azimuths 2πd/M, d ≤ M/2, against ring a's point at azimuth 0: the
        // distances from coordinates (precise for nearby points) by the vectorised kernel loop,
        // then mirrored, so that c_ab(d) = c_ab(M − d) holds exactly.
        let half = per_ring / 2;
        let angle = |d: usize| std::f64::consts::TAU * d as f64 / per_ring as f64;
        let (cos, sin): (Vec<f64>, Vec<f64>) = (0..=half).map(|d| (angle(d).cos(), angle(d).sin())).unzip();
        let ring_points: Vec<PointsSoa> = (0..rings)
            .map(|b| PointsSoa {
                x: cos.iter().map(|c| s[b] * c).collect(),
                y: sin.iter().map(|v| s[b] * v).collect(),
                z: vec![z[b]; half + 1],
            })
            .collect();
        let dft = Dft::new(per_ring);
        // (B_f)_ab for a ≥ b, f ≤ M/2, written straight into the blocks. Two pairs per complex
        // transform (both sequences are real and even, so their transforms are real and
        // separate); pairs column by column (b, then a ≥ b), a batch at a time, so that each
        // block receives a contiguous run of a column per batch.
        let pairs: Vec<(usize, usize)> = (0..rings).flat_map(|b| (b..rings).map(move |a| (a, b))).collect();
        let (mut re, mut im, mut scratch) = (vec![0.0; per_ring], vec![0.0; per_ring], Vec::new());
        let fill = |(a, b): (usize, usize), out: &mut [f64]| {
            kernel.fill_against(&ring_points[b], 0, &Vec3::new(s[a], 0.0, z[a]), &mut out[..=half]);
            for d in half + 1..per_ring {
                out[d] = out[per_ring - d];
            }
            if a == b {
                out[0] += noise;
            }
        };
        const BATCH: usize = 16;
        let mut batch = vec![0.0; BATCH * (half + 1)];
        let mut assemble = |factors: &mut [Mat<f64>]| {
            for batch_pairs in pairs.chunks(BATCH) {
                for (chunk_index, chunk) in batch_pairs.chunks(2).enumerate() {
                    fill(chunk[0], &mut re);
                    match chunk.get(1) {
                        Some(&p) => fill(p, &mut im),
                        None => im.fill(0.0),
                    }
                    dft.transform(&mut re, &mut im, false, &mut scratch);
                    for (k, part) in [&re, &im].into_iter().enumerate().take(chunk.len()) {
                        let p = 2 * chunk_index + k;
                        batch[p * (half + 1)..(p + 1) * (half + 1)].copy_from_slice(&part[..=half]);
                    }
                }
                for (f, l) in factors.iter_mut().enumerate() {
                    for (p, &(a, b)) in batch_pairs.iter().enumerate() {
                        l[(a, b)] = batch[p * (half + 1) + f];
                    }
                }
            }
        };
        // Every diagonal entry of Q is κ(0) + σ_n².
        let mean_diag = kernel.diagonal() + noise;
        let mut factors: Vec<Mat<f64>> = (0..=half).map(|_| Mat::zeros(rings, rings)).collect();
        let mut mem = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
            rings,
            Par::Seq,
            Default::default(),
        ));
        let info = jitter_ladder(mean_diag, 0.0, |_, jitter| {
            // Each attempt assembles the blocks again: a failed factorisation overwrote them.
            assemble(&mut factors);
            for l in factors.iter_mut() {
                for b in 0..rings {
                    l[(b, b)] += jitter;
                }
                llt::factor::cholesky_in_place(
                    l.as_mut(),
                    Default::default(),
                    Par::Seq,
                    MemStack::new(&mut mem),
                    Default::default(),
                )
                .ok()?;
            }
            Some(condition_estimate(
                factors.iter().flat_map(|l| (0..rings).map(move |i| l[(i, i)])),
            ))
        })
        .map_err(|jitter| NotPositiveDefinite { n, jitter })?;
        Ok(RingFactor {
            layout,
            factors,
            dft,
            info,
        })
    }

    /// What the factorisation needed; the condition estimate is `(max L_ii / min L_ii)²` over
    /// all blocks (the blocks are `Q` in a unitary basis, so it bounds `Q`'s condition number
    /// from below, like the dense estimate).
    pub fn info(&self) -> FactorInfo {
        self.info
    }

    pub fn layout(&self) -> RingLayout {
        self.layout
    }

    /// `Q⁻¹ (r ⊗ 1)` for a right-hand side constant on each ring (`ring_values[a]` on ring
    /// `a`): `B_0 v = r`, expanded to every point of each ring.
    pub fn solve_ring_constant(&self, ring_values: &[f64]) -> Vec<f64> {
        let RingLayout { rings, per_ring } = self.layout;
        assert_eq!(ring_values.len(), rings, "one value per ring");
        let mut v = ring_values.to_vec();
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(rings, 1, Par::Seq));
        solve_block(&self.factors[0], &mut v, 1, &mut mem);
        v.iter().flat_map(|&x| std::iter::repeat_n(x, per_ring)).collect()
    }
}

/// Solves `L Lᵀ X = B` in place for the `J × k` column-major `b`, with `mem` at least faer's
/// scratch for a `J × k` solve.
fn solve_block(l: &Mat<f64>, b: &mut [f64], columns: usize, mem: &mut MemBuffer) {
    let j = l.nrows();
    let rhs = faer::MatMut::from_column_major_slice_mut(b, j, columns);
    llt::solve::solve_in_place(l.as_ref(), rhs, Par::Seq, MemStack::new(mem));
}

impl RingFactor {
    /// Solves `Q X = B` in place for `columns` right-hand sides, column-major
    /// (`b.len() == N · columns`): each column's rings to frequencies, one `J × 2k` block solve
    /// per distinct frequency for the `k` columns' real and imaginary parts together, and back.
    /// Each column gets the same arithmetic as a solve of its own, apart from the order in
    /// which faer sweeps the block's right-hand sides.
    pub fn solve_columns_in_place(&self, b: &mut [f64], columns: usize) {
        let RingLayout { rings, per_ring } = self.layout;
        let n = rings * per_ring;
        assert_eq!(
            b.len(),
            n * columns,
            "right-hand sides: N × columns, column-major"
        );
        let half = per_ring / 2;
        let mut scratch = Vec::new();
        // Each column's rings to frequencies: spec_{re,im}[c·N + a·M + f].
        let mut spec_re = b.to_vec();
        let mut spec_im = vec![0.0; b.len()];
        for r in (0..rings * columns).map(|ring| ring * per_ring..(ring + 1) * per_ring) {
            self.dft
                .transform(&mut spec_re[r.clone()], &mut spec_im[r], false, &mut scratch);
        }
        // One J × 2k solve (real and imaginary parts of every column) per distinct frequency;
        // B_{M−f} = B_f and b real make x̂(M − f) the conjugate of x̂(f).
        let mut rhs = vec![0.0; 2 * rings * columns];
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(
            rings,
            2 * columns,
            Par::Seq,
        ));
        for f in 0..=half {
            for c in 0..columns {
                for a in 0..rings {
                    rhs[2 * c * rings + a] = spec_re[c * n + a * per_ring + f];
                    rhs[(2 * c + 1) * rings + a] = spec_im[c * n + a * per_ring + f];
                }
            }
            solve_block(&self.factors[f], &mut rhs, 2 * columns, &mut mem);
            let g = (per_ring - f) % per_ring;
            for c in 0..columns {
                for a in 0..rings {
                    let (re, im) = (rhs[2 * c * rings + a], rhs[(2 * c + 1) * rings + a]);
                    spec_re[c * n + a * per_ring + f] = re;
                    spec_im[c * n + a * per_ring + f] = im;
                    if g != f {
                        spec_re[c * n + a * per_ring + g] = re;
                        spec_im[c * n + a * per_ring + g] = -im;
                    }
                }
            }
        }
        let scale = 1.0 / per_ring as f64;
        for r in (0..rings * columns).map(|ring| ring * per_ring..(ring + 1) * per_ring) {
            self.dft.transform(
                &mut spec_re[r.clone()],
                &mut spec_im[r.clone()],
                true,
                &mut scratch,
            );
            for (x, v) in b[r.clone()].iter_mut().zip(&spec_re[r]) {
                *x = v * scale;
            }
        }
    }
}

impl RingFactor {
    /// `N = J M`, the order of `Q`.
    pub fn n(&self) -> usize {
        self.layout.rings * self.layout.per_ring
    }

    /// `log det Q = Σ_{f < M} log det B_f` (the blocks are `Q` in a unitary basis), with the
    /// stored blocks `f ≤ M/2` counted twice where `B_f = B_{M−f}` is a distinct frequency.
    pub fn log_det(&self) -> f64 {
        let per_ring = self.layout.per_ring;
        self.factors
            .iter()
            .enumerate()
            .map(|(f, l)| {
                let multiplicity = if f == 0 || 2 * f == per_ring { 1.0 } else { 2.0 };
                multiplicity * super::lower_log_det((0..self.layout.rings).map(|i| l[(i, i)]))
            })
            .sum()
    }

    /// `diag(Q⁻¹)`: per block, `(B_f⁻¹)_aa` by forward substitution, summed over the
    /// frequencies with their multiplicities; the same on every point of a ring.
    pub fn inverse_diagonal(&self) -> Vec<f64> {
        let RingLayout { rings, per_ring } = self.layout;
        let half = per_ring / 2;
        let mut diag = vec![0.0; rings];
        let mut x = vec![0.0; rings];
        for (f, l) in self.factors.iter().enumerate() {
            // Frequencies f and M − f share a block; f = 0 and f = M/2 (M even) are their own.
            let multiplicity = if f == 0 || 2 * f == per_ring { 1.0 } else { 2.0 };
            debug_assert!(f <= half);
            for (a, out) in diag.iter_mut().enumerate() {
                // (B_f⁻¹)_aa = ‖L_f⁻¹ e_a‖², by forward substitution from row a.
                x[a..].fill(0.0);
                x[a] = 1.0;
                for j in a..rings {
                    let xj = x[j] / l[(j, j)];
                    x[j] = xj;
                    for k in j + 1..rings {
                        x[k] -= l[(k, j)] * xj;
                    }
                }
                *out += multiplicity * x[a..].iter().map(|v| v * v).sum::<f64>();
            }
        }
        diag.iter()
            .flat_map(|&d| std::iter::repeat_n(d / per_ring as f64, per_ring))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bq::factor::SpdWorkspace;
    use crate::bq::kernel::{Sobolev, SquaredExponential};
    use crate::sampling::rings;
    use crate::util::rng::stream;

    /// The direct DFT and the FFT agree, and inverse ∘ forward = M · identity.
    #[test]
    fn transforms_agree_and_invert() {
        let mut rng = stream(21, &[]);
        use rand::RngExt;
        for len in [1usize, 2, 8, 64] {
            let fft = Dft::new(len);
            let x: Vec<f64> = (0..len).map(|_| rng.random::<f64>() - 0.5).collect();
            let (mut re, mut im) = (x.clone(), vec![0.0; len]);
            let mut scratch = Vec::new();
            fft.transform(&mut re, &mut im, false, &mut scratch);
            for f in 0..len {
                let (mut sr, mut si) = (0.0, 0.0);
                for (m, v) in x.iter().enumerate() {
                    let t = -std::f64::consts::TAU * (f * m) as f64 / len as f64;
                    sr += v * t.cos();
                    si += v * t.sin();
                }
                assert!(
                    (re[f] - sr).abs() < 1e-12 && (im[f] - si).abs() < 1e-12,
                    "len {len} f {f}"
                );
            }
            fft.transform(&mut re, &mut im, true, &mut scratch);
            for m in 0..len {
                assert!((re[m] / len as f64 - x[m]).abs() < 1e-14 && im[m].abs() < 1e-12);
            }
        }
        // A length that is not a power of two takes the direct sum.
        let dft = Dft::new(6);
        let (mut re, mut im) = (vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0], vec![0.0; 6]);
        dft.transform(&mut re, &mut im, false, &mut Vec::new());
        assert!(re.iter().all(|&v| (v - 1.0).abs() < 1e-15) && im.iter().all(|&v| v.abs() < 1e-15));
    }

    fn kernels() -> [Kernel; 2] {
        [
            Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
            Kernel::SquaredExponential(SquaredExponential::new(1.0, 0.4).unwrap()),
        ]
    }

    fn rel(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().map(|v| v.abs()).fold(0.0, f64::max);
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
    }

    /// Solves (one and three right-hand sides), ring-constant solves and diag(Q⁻¹) against the dense Cholesky of the same Q
    /// (assembled from coordinates), to 1e-10 relative, for power-of-two and other M.
    #[test]
    fn matches_the_dense_solve() {
        use rand::RngExt;
        let mut rng = stream(22, &[]);
        for kernel in kernels() {
            for n in [8usize, 36, 100, 512, 2048] {
                let layout = rings::check(n).unwrap();
                let pts = rings::sample_set(n, &mut rng);
                let noise = 0.01;
                let ring = RingFactor::new(&pts, layout, &kernel, noise).unwrap();
                let mut dense = SpdWorkspace::new();
                dense
                    .factor_entries(n, |i, j| {
                        kernel.eval(&pts[i], &pts[j]) + if i == j { noise } else { 0.0 }
                    })
                    .unwrap();
                let b: Vec<f64> = (0..n).map(|_| rng.random::<f64>() - 0.3).collect();
                let (mut x_ring, mut x_dense) = (b.clone(), b.clone());
                ring.solve_columns_in_place(&mut x_ring, 1);
                dense.solve_in_place(&mut x_dense);
                assert!(
                    rel(&x_ring, &x_dense) < 1e-10,
                    "{kernel} n={n}: {}",
                    rel(&x_ring, &x_dense)
                );
                // Three right-hand sides at once, each against its own dense solve.
                let mut columns: Vec<f64> = (0..3 * n).map(|_| rng.random::<f64>() - 0.5).collect();
                let mut want = columns.clone();
                ring.solve_columns_in_place(&mut columns, 3);
                for (got, want) in columns.chunks(n).zip(want.chunks_mut(n)) {
                    dense.solve_in_place(want);
                    assert!(rel(got, want) < 1e-10, "{kernel} n={n}: {}", rel(got, want));
                }
                let r: Vec<f64> = (0..layout.rings).map(|a| 1.0 + a as f64).collect();
                let mut want: Vec<f64> = (0..n).map(|i| r[i / layout.per_ring]).collect();
                dense.solve_in_place(&mut want);
                let got = ring.solve_ring_constant(&r);
                assert!(rel(&got, &want) < 1e-10, "{kernel} n={n}: {}", rel(&got, &want));
                let (dr, dd) = (ring.inverse_diagonal(), dense.inverse_diagonal());
                assert!(rel(&dr, &dd) < 1e-10, "{kernel} n={n}: {}", rel(&dr, &dd));
            }
        }
    }
}
