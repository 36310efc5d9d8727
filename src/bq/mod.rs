//! Bayesian quadrature on the hemisphere, in the order of the maths (`docs/math.md` §§3–9):
//! kernels (§4), their exact means (§4), factors of `Q = K + σ_n² I` (§5), weights and
//! amplitudes (§5–7), the model a user writes, the estimators (MC, BMC, BMCP, Bayes–Sard), the
//! rule that turns samples into an estimate, the choice among a fitted model's grid (§9), and the
//! stages a tolerance or adaptive run walks.
//!
//! Each layer imports only from the layers above it in this list.

pub mod estimator;
pub mod factor;
pub mod fitted;
pub mod kernel;
pub mod kernel_mean;
pub mod light_measure;
pub mod model;
pub mod rule;
pub mod stages;
pub mod weights;
