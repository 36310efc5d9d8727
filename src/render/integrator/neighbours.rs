//! BMCP in the renderer (thesis §3.2.5, math.md §4): the constant prior of a pixel from its
//! neighbours.
//!
//! Pass 1 renders every other pixel (checkerboard, `(i + j)` even) with plain BMC; pass 2
//! renders the rest with the constant prior `c = mean(available 4-neighbour estimates) / (2π)`
//! per channel. The neighbours estimate the same integral `∫ f dω`, and `2πc` is the integral
//! of the constant `c`, so `c` is the constant with the neighbours' integral.
//!
//! That prior is wrong wherever a neighbour sees another surface: across the sphere's
//! silhouette a ground pixel lends its brightness to a sphere pixel (thesis §4.3, whose future
//! work proposes weighting the neighbours). [`NeighbourPrior::EdgeAware`] does that: neighbours
//! are weighted by the similarity of their normals and rejected across depth discontinuities
//! ([`edge_aware_prior`]).

use crate::render::scene::Rgb;
use crate::util::geometry::Vec3;
use std::f64::consts::TAU;

/// Where BMCP's constant comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NeighbourPrior {
    /// The plain mean of the available 4-neighbours ([`neighbour_prior`]; thesis §3.2.5).
    Mean,
    /// The mean weighted by normal similarity, with neighbours across a silhouette or depth
    /// discontinuity rejected ([`edge_aware_prior`]); integrator `bmcp-edge`.
    EdgeAware,
}

/// What the edge-aware prior knows of a pixel's primary hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelGeometry {
    /// Unit surface normal at the hit.
    pub normal: Vec3,
    /// Distance from the camera along the primary ray (`t`, the ray direction being unit).
    pub depth: f64,
}

/// Normal exponent `α` of the edge-aware weights `(n·n_k)^α`. At 32 a neighbour whose normal
/// differs by 10° keeps 0.61 of the weight, by 20° 0.14, by 30° 0.01: neighbours on one smooth
/// surface count (almost) fully — in the default scene at 256×256 the largest angle between
/// the normals of two neighbouring pixels of one surface is 9.4°, at the sphere's rim — and
/// across a crease they do not.
pub const EDGE_NORMAL_EXPONENT: f64 = 32.0;

/// Relative depth jump `τ` beyond which a neighbour is on another surface: `|t_k − t| > τ t`.
/// In the default scene at 256×256 neighbouring pixels of one surface differ in depth by at
/// most 2.6% (the sphere's grazing rim), so 0.05 never splits a surface; across the sphere's
/// silhouette the jump can be as small as 1.9% (where the sphere meets the ground), so there
/// the normal test does the rejecting (every such pair has normals facing apart), and the depth
/// test guards the case it cannot see: parallel surfaces at different depths.
/// `tests/it/render/analytic.rs` (`edge_weights_separate_the_scene_surfaces`) measures both margins.
pub const EDGE_DEPTH_TOLERANCE: f64 = 0.05;

/// Normals closer than this cosine (30°) count as the same surface for the edge mask.
const EDGE_MASK_COSINE: f64 = 0.866_025_403_784_438_6;

/// Whether pixel `(i, j)` belongs to the first (plain BMC) pass.
#[inline]
pub fn first_pass(i: usize, j: usize) -> bool {
    (i + j).is_multiple_of(2)
}

/// `c` for pixel `(i, j)` from the first-pass `estimates` (row-major, `None` where the primary
/// ray hit nothing and there is no integral): the mean of the available neighbours left, right,
/// above and below, divided by `2π`; zero (plain BMC) when none is available.
pub fn neighbour_prior(estimates: &[Option<Rgb>], width: usize, height: usize, i: usize, j: usize) -> Rgb {
    let mut sum = [0.0; 3];
    let mut n = 0usize;
    let mut add = |ii: usize, jj: usize| {
        if let Some(e) = estimates[jj * width + ii] {
            for c in 0..3 {
                sum[c] += e[c];
            }
            n += 1;
        }
    };
    if i > 0 {
        add(i - 1, j);
    }
    if i + 1 < width {
        add(i + 1, j);
    }
    if j > 0 {
        add(i, j - 1);
    }
    if j + 1 < height {
        add(i, j + 1);
    }
    if n == 0 {
        return [0.0; 3];
    }
    sum.map(|s| s / n as f64 / TAU)
}

/// The edge-aware weight of neighbour `k` for a pixel with geometry `g`:
///
/// `a_k = 0` if `n·n_k ≤ 0` or `|t_k − t| > τ t` (another surface: a silhouette or a depth
/// discontinuity), else `a_k = (n·n_k)^α`, with `α` = [`EDGE_NORMAL_EXPONENT`] and `τ` =
/// [`EDGE_DEPTH_TOLERANCE`]. Neighbours with the pixel's own normal and depth weigh 1.
#[inline]
pub fn edge_weight(g: &PixelGeometry, k: &PixelGeometry) -> f64 {
    let cos = g.normal.dot(&k.normal);
    if cos <= 0.0 || (k.depth - g.depth).abs() > EDGE_DEPTH_TOLERANCE * g.depth {
        0.0
    } else {
        cos.min(1.0).powf(EDGE_NORMAL_EXPONENT)
    }
}

/// The 4-neighbours `(i', j')` of `(i, j)` inside a `width × height` image: left, right,
/// above, below (the order of the sums, so results do not depend on anything else).
fn four_neighbours(width: usize, height: usize, i: usize, j: usize) -> impl Iterator<Item = (usize, usize)> {
    [
        (i > 0).then(|| (i.wrapping_sub(1), j)),
        (i + 1 < width).then_some((i + 1, j)),
        (j > 0).then(|| (i, j.wrapping_sub(1))),
        (j + 1 < height).then_some((i, j + 1)),
    ]
    .into_iter()
    .flatten()
}

/// The edge-aware constant for pixel `(i, j)`: `c = Σ_k a_k e_k / (2π Σ_k a_k)` over the
/// available 4-neighbours `k` with first-pass estimates `e_k`, `a_k` = [`edge_weight`]; zero
/// (plain BMC) when every weight is 0, like [`neighbour_prior`] without neighbours. With every
/// `a_k = 1` it is [`neighbour_prior`]. `geometry` is row-major, `None` for background pixels.
pub fn edge_aware_prior(
    estimates: &[Option<Rgb>],
    geometry: &[Option<PixelGeometry>],
    width: usize,
    height: usize,
    i: usize,
    j: usize,
) -> Rgb {
    let Some(g) = geometry[j * width + i] else {
        return [0.0; 3];
    };
    let mut sum = [0.0; 3];
    let mut total = 0.0;
    for (ii, jj) in four_neighbours(width, height, i, j) {
        let k = jj * width + ii;
        if let (Some(e), Some(gk)) = (estimates[k], geometry[k]) {
            let a = edge_weight(&g, &gk);
            if a > 0.0 {
                for c in 0..3 {
                    sum[c] += a * e[c];
                }
                total += a;
            }
        }
    }
    if total == 0.0 {
        return [0.0; 3];
    }
    sum.map(|s| s / total / TAU)
}

/// The edge mask: hit pixels with a 4-neighbour that is background, has a normal more than 30°
/// away, or lies beyond the depth tolerance [`EDGE_DEPTH_TOLERANCE`] — the silhouettes and
/// creases where a neighbour prior can mislead. Row-major; background pixels are not edges.
pub fn edge_mask(geometry: &[Option<PixelGeometry>], width: usize, height: usize) -> Vec<bool> {
    let mut mask = vec![false; geometry.len()];
    for j in 0..height {
        for i in 0..width {
            let Some(g) = geometry[j * width + i] else {
                continue;
            };
            mask[j * width + i] =
                four_neighbours(width, height, i, j).any(|(ii, jj)| match geometry[jj * width + ii] {
                    None => true,
                    Some(k) => {
                        g.normal.dot(&k.normal) < EDGE_MASK_COSINE
                            || (k.depth - g.depth).abs() > EDGE_DEPTH_TOLERANCE * g.depth
                    }
                });
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geo(normal: [f64; 3], depth: f64) -> Option<PixelGeometry> {
        Some(PixelGeometry {
            normal: Vec3::new(normal[0], normal[1], normal[2]).normalize(),
            depth,
        })
    }

    /// Where every neighbour has the pixel's normal and depth, the edge-aware prior is the
    /// plain neighbour mean, bit for bit up to the division order.
    #[test]
    fn edge_aware_prior_is_the_plain_mean_on_a_flat_surface() {
        let e = vec![
            None,
            Some([1.0, 2.0, 3.0]),
            None,
            Some([0.5, 0.25, 4.0]),
            None,
            Some([3.0, 4.0, 5.0]),
            None,
            Some([2.0, 1.0, 0.0]),
            None,
        ];
        let g = vec![geo([0.0, 1.0, 0.0], 5.0); 9];
        let plain = neighbour_prior(&e, 3, 3, 1, 1);
        let edge = edge_aware_prior(&e, &g, 3, 3, 1, 1);
        for c in 0..3 {
            assert!(
                (plain[c] - edge[c]).abs() <= 1e-15 * plain[c].abs(),
                "{plain:?} vs {edge:?}"
            );
        }
        // Only neighbours weighed equally reduce to the mean: tilt one by 10°.
        let mut tilted = g.clone();
        tilted[1] = geo([0.0, 10f64.to_radians().cos(), 10f64.to_radians().sin()], 5.0);
        let w = 10f64.to_radians().cos().powf(EDGE_NORMAL_EXPONENT);
        let want = (w * 2.0 + 0.25 + 4.0 + 1.0) / (w + 3.0) / TAU;
        let got = edge_aware_prior(&e, &tilted, 3, 3, 1, 1)[1];
        assert!((got - want).abs() < 1e-15, "{got} vs {want}");
    }

    /// Neighbours across a silhouette — a normal facing away, or the ground far behind the
    /// sphere — get no weight; with all of them rejected the prior is 0 (plain BMC).
    #[test]
    fn edge_aware_prior_rejects_neighbours_across_a_silhouette() {
        let here = PixelGeometry {
            normal: Vec3::new(1.0, 0.0, 0.0),
            depth: 6.0,
        };
        let ground_behind = PixelGeometry {
            normal: Vec3::new(1.0, 0.0, 0.0),
            depth: 6.0 * (1.0 + 2.0 * EDGE_DEPTH_TOLERANCE),
        };
        let facing_away = PixelGeometry {
            normal: Vec3::new(-0.1, 1.0, 0.0).normalize(),
            depth: 6.0,
        };
        assert_eq!(edge_weight(&here, &ground_behind), 0.0);
        assert_eq!(edge_weight(&here, &facing_away), 0.0);
        assert_eq!(edge_weight(&here, &here), 1.0);
        // Pixel (1, 0) of a 3×1 image: left neighbour behind, right one the same surface.
        let e = vec![Some([9.0; 3]), None, Some([1.0, 2.0, 3.0])];
        let g = vec![Some(ground_behind), Some(here), Some(here)];
        assert_eq!(
            edge_aware_prior(&e, &g, 3, 1, 1, 0),
            [1.0 / TAU, 2.0 / TAU, 3.0 / TAU]
        );
        let g = vec![Some(ground_behind), Some(here), Some(facing_away)];
        assert_eq!(edge_aware_prior(&e, &g, 3, 1, 1, 0), [0.0; 3]);
        // The edge mask marks the middle pixel (a rejected neighbour) and both ends (theirs).
        assert_eq!(edge_mask(&g, 3, 1), vec![true, true, true]);
        let flat = vec![Some(here); 3];
        assert_eq!(edge_mask(&flat, 3, 1), vec![false; 3]);
        assert_eq!(
            edge_mask(&[None, Some(here), Some(here)], 3, 1),
            vec![false, true, false]
        );
    }

    #[test]
    fn prior_is_the_neighbour_mean_over_two_pi() {
        // 3×2 image; pixel (1, 0) has neighbours (0, 0), (2, 0), (1, 1); (2, 0) has no hit.
        let e = vec![
            Some([1.0, 2.0, 3.0]),
            None,
            None,
            None,
            Some([3.0, 4.0, 5.0]),
            None,
        ];
        let c = neighbour_prior(&e, 3, 2, 1, 0);
        assert_eq!(c, [2.0 / TAU, 3.0 / TAU, 4.0 / TAU]);
        assert_eq!(neighbour_prior(&[None; 6], 3, 2, 1, 0), [0.0; 3]);
        assert!(first_pass(0, 0) && !first_pass(1, 0) && first_pass(1, 1));
    }
}
