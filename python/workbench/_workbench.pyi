"""Type stubs of ``workbench._workbench``, the compiled module that ``workbench`` re-exports.

Arrays: ``Points`` are float64 numpy arrays of shape ``(n, 3)``, one direction per row, in the
local frame (normal ``+z``): unit vectors (``|‖p‖ − 1| ≤ 1e-9``) with ``z ≥ 0``. ``Values`` are
float64 arrays of shape ``(n,)``, finite, one per point in the same order. Anything else raises
``ValueError`` naming the argument and the value (``points[3]: (1, 0, 1) is not a unit vector
(norm 1.4142135623730951)``).

Models: ``kernel`` is ``None`` (Sobolev, s = 1.4), a name (``"sobolev"``, ``"se"``,
``"fitted"``: that kernel with its defaults) or a dict as in experiment files
(``{"type": "sobolev", "s": 2.75}``, ``{"type": "se", "sigma": 1, "length": 0.5}``,
``{"type": "fitted", "grid": {"s": [...], "noise": [...]}}``); ``noise`` is σ_n² (default 0.01);
``kernel_mean`` is ``"exact"`` (default), ``"mc"`` or ``"mc-shared"`` with
``kernel_mean_samples`` M (default 10 000). The defaults and messages are the experiment files'.
"""

from os import PathLike
from typing import Any, Callable, Literal, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

Points = npt.NDArray[np.float64]
Values = npt.NDArray[np.float64]
Kernel = Union[None, str, Mapping[str, Any]]
MethodName = Literal["mc", "bmc", "bmcp", "bsq"]
WeightedMethod = Literal["bmc", "bmcp", "bsq"]
DesignName = Literal["uniform", "cosine", "fibonacci", "stratified", "sobol", "rings"]
ScaleName = Literal["unit", "ml", "loo"]
KernelMean = Literal["exact", "mc", "mc-shared"]

__version__: str
METHODS: list[str]
"""Every estimator's name: ``["mc", "bmc", "bmcp", "bsq"]``."""
DESIGNS: list[str]
"""Every sampling design's name: ``["uniform", "cosine", "fibonacci", "stratified", "sobol", "rings"]``."""

def rule(
    n: int = 64,
    *,
    design: DesignName = "uniform",
    kernel: Kernel = None,
    noise: Optional[float] = None,
    kernel_mean: Optional[KernelMean] = None,
    kernel_mean_samples: Optional[int] = None,
    method: WeightedMethod = "bmc",
    seed: int = 0,
    values: Optional[Values] = None,
) -> tuple[Points, Values]:
    """The rule ``workbench rule --n N --seed S [--design D] …`` writes: ``(points, weights)``,
    bit for bit the CLI's CSV.

    ``design="rings"`` takes N = J·M (the ring solver; up to 65536 points with exact kernel
    means), other designs up to 16384. ``method="bsq"`` gives the Bayes–Sard weights (summing to
    2π; N ≥ 2); ``"bmcp"`` shares BMC's. A fitted ``kernel`` needs ``values`` (the integrand at
    the points that ``rule`` with the same ``n``, ``seed`` and ``design`` draws): the weights are
    those of the grid model whose marginal likelihood of the values is largest. Numerical
    warnings (jitter, ill-conditioning, a negative posterior variance) are ``RuntimeWarning``s.

    >>> points, weights = rule(64, seed=7)
    >>> points.shape, round(float(weights.sum()), 6)
    ((64, 3), 6.251944)
    """

def weights(
    points: Points,
    *,
    kernel: Kernel = None,
    noise: Optional[float] = None,
    kernel_mean: Optional[KernelMean] = None,
    kernel_mean_samples: Optional[int] = None,
    method: WeightedMethod = "bmc",
    seed: int = 0,
    values: Optional[Values] = None,
) -> Values:
    """The BMC (BMCP) or Bayes–Sard weights of given points: ``workbench rule --points FILE``,
    bit for bit (a dense solve, at most 16384 points). ``seed`` drives MC kernel means only;
    ``values`` as in :func:`rule` for a fitted kernel."""

def kernel_means(
    points: Points,
    *,
    kernel: Kernel = None,
    kernel_mean: Optional[KernelMean] = None,
    kernel_mean_samples: Optional[int] = None,
    seed: int = 0,
) -> Values:
    """The kernel means ``z_i = ∫_H k(x_i, ω) dω`` (math.md §4): exact (tabulated in the height
    ``x_i·n``), or the thesis's MC estimates (``"mc"``: fresh directions per point; ``"mc-shared"``:
    one set for all), drawn from ``seed`` as :func:`rule` draws them. Not for a fitted kernel."""

def prior_variance(kernel: Kernel = None) -> float:
    """``V̂ = ∫_H ∫_H k(ω, ω') dω dω'``, the prior variance of the integral (exact)."""

def fit(
    points: Points,
    values: Values,
    *,
    method: WeightedMethod = "bmc",
    grid: Optional[Mapping[str, Sequence[float]]] = None,
) -> dict[str, Any]:
    """The fitted model's choice on given points (math.md §9; ``workbench rule --points P --kernel
    fitted --values V``): every grid model (``grid={"s": [...], "noise": [...]}``, default s ∈
    {1.2, 1.6, 2.75, 3.75} × σ_n² ∈ {1e-2, 1e-8}) is factored and the one with the largest
    profiled log marginal likelihood (``"bsq"``: the restricted one) wins.

    Returns ``{"chosen": index, "model": "s=3.75 noise=1e-8", "s": 3.75, "noise": 1e-08,
    "grid": [{"s", "noise", "log_marginal_likelihood"}, ...], "weights": array}``.
    """

def estimate(
    method: MethodName,
    points: Points,
    values: Values,
    *,
    weights: Optional[Rule] = None,
    prior: Optional[float] = None,
    scale: Optional[ScaleName] = None,
    density: Optional[Literal["uniform", "cosine"]] = None,
) -> tuple[float, float]:
    """``(Î, sd)``: the estimate of ``∫_H f dω`` from the values at the points and the sd the
    estimator states (NaN where it states none: MC with one point) — the numbers of a
    ``trials.csv`` row, bit for bit.

    - ``"mc"``: ``(1/N) Σ f/p`` with ``p`` the ``density`` the points were drawn from
      (``"uniform"``, default, or ``"cosine"``); sd ``s/√N`` (Student-t, N − 1 dof).
    - ``"bmc"``, ``"bmcp"`` (``prior`` = its constant c, required), ``"bsq"`` (N ≥ 2): with the
      weights and factor of ``weights``, a :class:`Rule` on these very points (its ``points``);
      ``None`` builds the default model's rule (a factorisation per call: keep a Rule instead).
      ``scale`` is the amplitude of the sd: ``"ml"`` (default; Student-t with N, for bsq N − 1,
      dof), ``"unit"`` or ``"loo"`` (math.md §7). A fitted rule chooses its model for these
      values, as the runner does.

    What ``trials.csv``'s ``warnings`` column counts is a ``RuntimeWarning`` here: zero evidence
    (a fitted amplitude of exactly 0, e.g. all values 0 for ``"bmc"``: sd 0), an amplitude
    that overflowed to ∞ (values near 1e146 or larger: sd ∞), an estimate that is not finite.

    The call costs about 0.5 µs besides the estimate itself at N = 64 (docs/python.md).
    """

class Rule:
    """A quadrature rule kept for estimates: points, their BMC weights under a model and the
    factorisation of ``Q = K + σ_n² I`` (the ``ml``/``loo`` amplitudes solve with it). A fitted
    kernel keeps every grid model's weights, and every model's factor only when they all fit half
    the memory budget (``WORKBENCH_MEMORY``); otherwise each estimate factors the grid again, one
    model at a time, keeping the best so far (the same numbers, bit for bit; 3 factors in memory
    whatever the grid's size).

    ``Rule(points, ...)`` weights given points (a dense solve, as :func:`weights`);
    ``Rule(n=64, design=..., seed=...)`` draws them as :func:`rule` does (same points, same
    weights). ``seed`` also drives MC kernel means.
    """

    def __init__(
        self,
        points: Optional[Points] = None,
        *,
        n: Optional[int] = None,
        design: Optional[DesignName] = None,
        kernel: Kernel = None,
        noise: Optional[float] = None,
        kernel_mean: Optional[KernelMean] = None,
        kernel_mean_samples: Optional[int] = None,
        seed: int = 0,
    ) -> None: ...
    @property
    def points(self) -> Points:
        """The points, shape ``(n, 3)`` (a copy)."""
    @property
    def n(self) -> int:
        """The number of points."""
    @property
    def design(self) -> Optional[str]:
        """The design the points were drawn with, None for given points."""
    @property
    def fitted(self) -> bool:
        """Whether the kernel is fitted: the weights then depend on the values."""
    @property
    def model(self) -> dict[str, Any]:
        """The resolved model (kernel with parameters, noise, kernel mean), as a manifest states it."""
    def __len__(self) -> int: ...
    def weights(self, method: WeightedMethod = "bmc", values: Optional[Values] = None) -> Values:
        """The weights for ``method`` (``"bsq"``: Bayes–Sard's); a fitted rule needs the values
        that choose its model."""
    def diagnostics(self, method: WeightedMethod = "bmc", values: Optional[Values] = None) -> dict[str, Any]:
        """The weight set's diagnostics as ``workbench rule --summary`` states them (``n``,
        ``weight_sum``, ``negative_weights``, ``min_weight``, ``max_weight``, ``jitter``,
        ``condition_estimate``, ``prior_variance``, ``posterior_variance`` (raw, unit amplitude),
        ``posterior_sd``, ``warnings``); a fitted rule adds ``chosen``, ``model`` and
        ``log_marginal_likelihoods``."""
    def q_inverse(self) -> npt.NDArray[np.float64]:
        """``Q⁻¹ = (K + σ_n² I)⁻¹``, shape ``(n, n)``, of a fixed model's rule: what a vectorised
        renderer needs for the ``ml`` amplitude ``λ̂ = YᵀQ⁻¹Y / N`` of many pixels at once."""
    def estimate(
        self,
        values: Values,
        method: WeightedMethod = "bmc",
        prior: Optional[float] = None,
        scale: Optional[ScaleName] = None,
    ) -> tuple[float, float]:
        """``(Î, sd)`` as :func:`estimate` with ``weights=self`` (without the points argument),
        with its ``RuntimeWarning``s."""

class Integrand:
    """An integrand of experiment files with its exact integral: ``Integrand("cos3")``
    (cos^k θ, truth 2π/(k+1)) or a family dict: ``{"type": "lobe", "axis": [...], "exponent":
    e}``, ``"cap"`` (``half_angle`` in degrees), ``"gaussian"`` (``sharpness``), each with
    ``"cosine": true`` for the × cos θ version and an optional ``"name"``; or a render-scene
    ``{"type": "pixel", "pixel": [i, j], "channel": "g", ...}``."""

    def __init__(self, spec: Union[str, Mapping[str, Any]]) -> None: ...
    @property
    def name(self) -> str:
        """The name in ``trials.csv`` (``cos3``, ``lobe8-tilt30``)."""
    @property
    def display_name(self) -> str:
        """For people: ``cos³θ``, ``Phong lobe e = 8, tilt 30°``."""
    @property
    def truth(self) -> float:
        """``I = ∫_H f dω``: the ``truth`` column of ``trials.csv``."""
    @property
    def constant_prior(self) -> float:
        """The oracle prior ``c = I/2π`` (BMCP's ``"prior": "analytic"``)."""
    def __call__(self, points: Points) -> Values:
        """``f`` at each direction."""

def run(
    spec: Union[Mapping[str, Any], str, PathLike[str]],
    *,
    integrands: Optional[Mapping[str, Callable[[Points], Values]]] = None,
    out: Optional[Union[str, PathLike[str]]] = None,
    threads: Optional[int] = None,
    tables: bool = False,
) -> dict[str, Any]:
    """Runs an experiment (a dict holding an experiment file's JSON, or such a file's path) and
    returns the rows of its ``trials.csv``, in its order, as columns: ``integrand``,
    ``estimator``, ``method``, ``design`` and (for plans with a fitted kernel) ``model`` are lists
    of str; ``n``, ``trial``, ``warnings`` int64 arrays; the rest float64 arrays with NaN where
    the CSV is empty. ``pandas.DataFrame(run(spec))`` is the CSV as a frame. Every number is the
    CLI's to the bit, whatever ``threads``. Without ``out`` it writes no files.

    ``integrands`` maps names to your own integrands: callables taking a float64 array of shape
    ``(n, 3)`` (unit directions, ``z ≥ 0``) and returning ``n`` values (anything
    ``numpy.asarray(…, dtype=float64)`` turns into shape ``(n,)``; complex values and strings are
    refused, not converted), called once per trial's point
    set, never per point, from the run's worker threads (one at a time, holding the GIL): they
    must be pure functions of the points. The spec names each as ``{"type": "python", "name":
    NAME}`` with optional ``"truth"`` (∫ f dω if known), ``"tolerance"`` (the absolute error
    estimate of the computed truth; default 1e-10 · ∫|f| dω) and ``"display_name"``. Without a
    truth it is computed by adaptive Gauss–Kronrod cubature over the hemisphere; its error
    estimate goes into ``manifest.json`` (``truth_error_estimate``). A callable that raises,
    returns another shape or non-finite values is a ``ValueError`` naming the integrand, the
    trial and N, and nothing is written.

    With ``out`` (a folder) it writes what ``workbench run FILE --out OUT`` writes — CSVs,
    figures, summary, checks, manifest — and returns ``{"out": str, "report": str, "passed":
    bool}``: the folder, the text the CLI prints and whether every check passed.

    With ``tables=True`` it returns every table of the run as columns instead: ``{"trials": …,
    "summary": …, "stopping_trials": …, "stopping_summary": …}`` — ``trials.csv`` (as above),
    ``summary.csv`` and, for tolerance estimators, ``stopping_trials.csv`` (per trial the points
    used, ``n_used``) and ``stopping_summary.csv`` (``{}`` without tolerance estimators), each the
    CLI's CSV to the bit. With ``out`` too, these keys are added to the folder's dict.

    Errors are the CLI's messages: for a file ``file: path: message``, for a dict ``path:
    message``.
    """

def trial_points(seed: int, design: DesignName, n: int, trial: int) -> Points:
    """The points ``design`` draws at ``n`` in trial ``trial`` of an experiment with master seed
    ``seed``: what every estimator with that design sees in that row of ``trials.csv``."""

def to_world(points: Points, normal: Sequence[float], azimuth: Optional[float] = None) -> Points:
    """Carries directions in the local frame (normal ``+z``) to the world: each point rotated by
    ``azimuth`` (radians, default 0) about ``+z``, then mapped by the orthonormal frame
    ``(t, b, n)`` about the unit ``normal`` (normalised; Duff et al., JCGT 2017 — the frame of the
    renderer and of the ``envmap`` integrand). A rule's weights are invariant under this
    rotation (its kernels are isotropic), so ``Rule.estimate(values)`` with values taken at
    ``to_world(rule.points, n, φ)`` estimates the integral over the hemisphere about ``n``.

    >>> points, _ = rule(16, seed=1)
    >>> world = to_world(points, [0.0, 1.0, 0.0], azimuth=0.5)
    >>> bool(abs(world[:, 1] - points[:, 2]).max() < 1e-12)
    True
    """

def check_memory(what: str, bytes: int) -> None:
    """The library's memory guard: ``ValueError`` with one line naming ``what``, the bytes and the
    budget (``WORKBENCH_MEMORY``, else 3/4 of the machine's memory) when ``bytes`` is more than
    the budget or cannot be allocated now. For callers that plan many rules at once (the Mitsuba
    integrator's ``rules × n²`` factors)."""

def pss_rules(n: int, sets: int, order: int, seed: int = 0) -> dict[str, Any]:
    """``bq-pss``'s ``sets`` point sets of ``n`` Owen-scrambled Sobol points in ``[0, 1)²`` (a fresh
    scramble per set from ``seed``) with the product Sobolev kernel of ``order`` (1 or 2; math.md
    §11 (a)), whose kernel mean is 1, so the weights depend on the points only. Returns
    ``{"points": (sets, n, 2), "bmc_weights": (sets, n) = Q⁻¹1, "bsq_weights": (sets, n) (summing
    to 1), "bmc_var1": (sets,) = 1 − 1ᵀQ⁻¹1, "bsq_var1": (sets,) = (1 − 1ᵀQ⁻¹1)/1ᵀQ⁻¹1,
    "q_inverse": (sets, n, n), "jitter": (sets,)}``, every number the library's (``Q⁻¹`` by its
    Cholesky solves, with the jitter its ladder added)."""
