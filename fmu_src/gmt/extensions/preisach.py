"""Rate-independent hysteresis: the classical Preisach model with a general density.

A Preisach model (Preisach 1935; Mayergoyz, *Mathematical Models of
Hysteresis and Their Applications*, Elsevier 2003, ch. 1) is a population of
elementary hysterons: relays R_{a,b} with up-switching field a and
down-switching field b <= a, output +1 after H has risen to a and -1 after it
has fallen to b. Written in the coercive field h_c = (a - b)/2 and the
interaction field h_u = (a + b)/2, a density rho(h_c, h_u) >= 0 over the
half-plane h_c > 0 gives the magnetisation

    M_P(t) = int int rho(h_c, h_u) R_{h_u + h_c, h_u - h_c}[H](t) dh_c dh_u.

The model is linear in rho. The density here is general: nonnegative values
w_n at the nodes of a grid, h_c geometric from :data:`COERCIVE_GRID` and h_u
uniform over :data:`INTERACTION_GRID` (both in units of the largest field
amplitude of the data, H_max), interpolated bilinearly (in ln h_c and h_u)
between the nodes, over the Preisach triangle a <= H_max, b >= -H_max (relays
outside it never switch in the data: their state is the record's history).
w_n is the saturation magnetisation of node n's share of the
population [A/m] (the relays under its interpolation weight), so M_P is
sum_n w_n R_n[H] with R_n the weighted mean of the relays of node n. A
nonnegative density makes every relay's loop run anticlockwise in (H, M), so
the loss per cycle, the loop area, is never negative (Mayergoyz 2003, sec. 1.2).
Saturating relays (a population that switches whole within the drive's
amplitude), asymmetric loops (a density off h_u = 0) and a Prandtl-Ishlinskii
operator (a density spread along h_u, the plays' limit) are all members.

Periodic form: for H = H_m cos(theta) a relay that switches (a <= H_m,
b >= -H_m) is +1 for theta in [0, theta_b) and [2 pi - theta_a, 2 pi),
theta_x = arccos(x/H_m), -1 in between; its Fourier coefficients are exact,

    c_k = 2 (e^{j k theta_a} - e^{-j k theta_b}) / (j pi k),   k >= 1,
    c_0 = 2 (theta_a + theta_b)/pi - 2 - 2 s_d,

(derived for this module), the output being c_0/2 + Re sum_k c_k e^{j k theta}, s_d
the relay's demagnetised state (up for h_u < 0, down for h_u > 0; Mayergoyz 2003,
sec. 1.3). **M_P is measured from the demagnetised state**: the paper's M_b (eq 25) is
the rod's magnetisation at rest under the magnet's bias, and the relays' rest states are
part of it, so M_P = 0 at rest. Counted from all relays down (or from their sum), an
asymmetric density (loop centres off h_u = 0) would move the operating point of eq 25
by a constant its weights fix, changing y's harmonics against B's with nothing to set
it (on labsim's Preisach data, loop centres 0.5 kA/m off: y's held-out excess 575 on
96 features, 84 measured from the demagnetised state), and the time-stepped
form would start away from M_b. A relay that cannot switch up (a > H_m) ends down,
one that cannot switch down (b < -H_m) ends up, one that does neither keeps its
demagnetised state: each of them is in its rest state, and adds nothing. The node
outputs are summed over :data:`SUBGRID` relays per grid cell and axis, and
synthesised from their first :data:`PERIODIC_HARMONICS` harmonics (a band whose
square, the force of eq 25, the steady-state evaluation samples without aliasing,
:data:`gmt.extensions.steady.GRID`).

**Rate factor.** Measured populations switch less at higher drive
frequencies: a relay needs time to switch (a wall moves at a finite speed), so
the share that completes its switching falls with the rate (Mayergoyz's
dynamic Preisach models, IEEE Trans. Magn. 24 (1988) 2925-2927, make the
density depend on the input's rate). Here that share is one factor of the
drive frequency on the whole population, g(f) = 1/(1 + (f/f_r)^q), two more
unknowns; f_r -> infinity (its upper bound, 10^4.5 Hz) is the classical
rate-independent model, and the loop still stays open as f -> 0.

Time-stepped form: the same relays, each holding its state, switched by the
held H of each step (:meth:`PreisachForm.adjust`), their weights times g at
the operating point's frequency.

The diagnosis fits the node weights as a nonnegative least-squares problem with
a smoothness penalty (:mod:`smeha.diagnose.fit`): the family's unknowns are
linear, and its effective number of parameters is the trace of the penalised
fit's hat matrix, not the number of nodes.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..errors import ParameterError
from ._base import HIGHER_HARMONICS, Extension, FitSpec, Parameter
from .magnetic import MagnetizationStage

#: Coercive nodes: (first, last, count), geometric, in units of H_max. 11 nodes space them
#: a factor 1.42 apart (0.35 in ln h_c), the log-spread of a single population of
#: Terfenol-D's coercive fields as labsim draws them (0.2-0.45). At 6 nodes (a factor 2.0,
#: 0.70 in ln h_c) a narrow population comes out as the hat of one node: on labsim's
#: bimodal density (seed 100 at 800 samples a period, log-spreads 0.20 and 0.29) the
#: density's held-out excess chi^2 is 1.2e6 in y and 3.9e6 in B; at 11 nodes 6.2e3 and
#: 7.9e4, and an eddy form beside it then removes 64 % of what the density leaves where
#: at 6 nodes it buys B with y.
COERCIVE_GRID = (0.03, 1.0, 11)
#: Interaction nodes: (first, last, count), uniform, in units of H_max. 19 nodes space them
#: H_max/9 apart, 1.6 kA/m at the 14.8 kA/m of a 1 A drive: the order of Terfenol-D's
#: coercive field (1-2 kA/m; Engdahl (ed.), *Handbook of Giant Magnetostrictive
#: Materials*, 2000, ch. 1), so that a population whose loop centres spread that little is
#: held by the density. At 7 nodes (4.9 kA/m apart) such a narrow population came out as a
#: broad one: on labsim's Preisach data (seeds 100-107, apart from the detection study's)
#: the fitted y missed by 0.4-2.5 um and B's held-out excess stayed 5-10 % of the paper's
#: model's; at 19 nodes 0.03-0.17 um.
INTERACTION_GRID = (-1.0, 1.0, 19)
#: The finer grid (coercive, interaction) of :class:`FinerPreisachForm`: 1.5 times as many
#: nodes along each axis over the same range (0.23 in ln h_c, H_max/13.5 in h_u); why, and
#: what it changed on labsim's data: :mod:`smeha.diagnose.resolution`.
FINER_GRID = ((0.03, 1.0, 16), (-1.0, 1.0, 28))
#: Relays per grid cell along each axis (the density's quadrature).
SUBGRID = 6
#: Harmonics of the periodic output kept: 24, so that the force's square of it (eq 25)
#: stays below the Nyquist harmonic of the steady state's 128 points. y's and B's first 8
#: harmonics differ from 48 kept by 9e-7 of |Y_1| and 1e-15 of |B_1| (a density fitted
#: to labsim's Preisach data, 5-400 Hz; 1 % of a harmonic's standard deviation at 0.05 um
#: noise), and each new field amplitude (an eddy form beside the density changes them
#: with its time constant) costs half as much.
PERIODIC_HARMONICS = 24


@functools.lru_cache(maxsize=8)
def node_grid(field_max, coercive=COERCIVE_GRID, interaction=INTERACTION_GRID):
    """(h_c nodes, h_u nodes) for H_max [A/m], [A/m] (read-only; cached: every evaluation
    of the form asks)."""
    c0, c1, nc = coercive
    u0, u1, nu = interaction
    out = (field_max * np.geomspace(c0, c1, int(nc)),
           field_max * np.linspace(u0, u1, int(nu)))
    for a in out:
        a.flags.writeable = False
    return out


#: Field amplitudes (units of H_max, evenly spaced up to 1) at which
#: :func:`projected_weights` matches a density's output on another grid.
PROJECTION_AMPLITUDES = 24


def projected_weights(weights, grid, finer_grid):
    """The node weights [A/m] on ``finer_grid`` whose periodic output is nearest that of
    ``weights`` on ``grid`` (each a (coercive, interaction) pair of (first, last, count),
    in units of H_max): the nonnegative least-squares fit (Lawson & Hanson 1974, ch. 23)
    of the finer nodes' harmonics c_0..c_K to the density's at
    :data:`PROJECTION_AMPLITUDES` field amplitudes from H_max/24 to H_max. The same loops
    at every drive level the data hold, a start for the finer fit, not a fit.

    Interpolating the density bilinearly instead misses its loops by up to 3 % of their
    swing (a density that curves within one coarse cell), and the diagnosis' training
    chi^2 rises from 1.8e3 to 6.2e7 (labsim's Preisach data, seed 3 at 800 samples a
    period); projected, to 2.3e4, the output within 0.3 %.
    """
    from scipy.optimize import nnls  # the diagnosis' only: the FMU's path imports numpy alone

    target = _projection_harmonics(grid) @ np.asarray(weights, float)
    fine, _ = nnls(_projection_harmonics(finer_grid), target, maxiter=100 * target.size)
    return fine


@functools.lru_cache(maxsize=4)
def _projection_harmonics(grid):
    """The nodes' harmonics of ``grid`` at :func:`projected_weights`' amplitudes, real and
    imaginary parts as rows: (amplitudes x 2 (K + 1), nodes), read-only (cached: every
    finer fit of a diagnosis asks the same two grids). Made past
    :func:`_node_harmonics_cached`: these amplitudes are not the data's, and that cache is
    kept for the fits'."""
    amplitudes = np.arange(1, PROJECTION_AMPLITUDES + 1) / PROJECTION_AMPLITUDES
    nodes = tuple(tuple(float(v) for v in axis) for axis in node_grid(1.0, *grid))
    out = np.vstack([_node_harmonics_cached.__wrapped__(
        *nodes, float(a), PERIODIC_HARMONICS).view(float).T for a in amplitudes])
    out.flags.writeable = False
    return out


def _hat_weights(nodes, points, log=False):
    """Linear interpolation weights of ``points`` on ``nodes``: (points, nodes)."""
    x = np.log(nodes) if log else np.asarray(nodes, float)
    p = np.log(points) if log else np.asarray(points, float)
    eye = np.eye(x.size)
    return np.stack([np.interp(p, x, eye[n]) for n in range(x.size)], axis=-1)


@functools.lru_cache(maxsize=16)
def _relays(coercive, interaction, subgrid=SUBGRID):
    """The relays of the density's quadrature: (a, b, weight matrix relays x nodes).

    Each node's column sums to 1: its output R_n is the weighted mean of its relays.
    """
    a, b, inside, wc, wu, total = _relay_grid(coercive, interaction, subgrid)
    weight = np.einsum("in,jm->ijnm", wc, wu).reshape(inside.size, total.size)[inside.ravel()]
    return a, b, weight / np.where(total > 0, total, 1.0).ravel()


@functools.lru_cache(maxsize=16)
def _relay_grid(coercive, interaction, subgrid=SUBGRID):
    """The relays on their (h_c, h_u) sub-grid: (a, b of those inside the Preisach
    triangle, which of the sub-grid's relays are inside (h_c x h_u), each sub-grid h_c's
    hat weights on the coercive nodes times its cell's extent, the same along h_u, the
    nodes' total relay weight (coercive x interaction nodes)). A node's weight on a relay
    is the product of its two factors: the node sums over the relays factorise
    (:func:`_node_harmonics_cached`)."""
    hc_nodes, hu_nodes = np.asarray(coercive), np.asarray(interaction)
    lc = np.log(hc_nodes)
    # relays at the centres of sub-cells between the nodes
    ts = (np.arange(subgrid) + 0.5) / subgrid
    hc = np.exp(np.concatenate([lc[i] + ts * (lc[i + 1] - lc[i]) for i in range(lc.size - 1)]))
    hu = np.concatenate([hu_nodes[i] + ts * (hu_nodes[i + 1] - hu_nodes[i])
                         for i in range(hu_nodes.size - 1)])
    wc = _hat_weights(hc_nodes, hc, log=True)  # (relays_c, nodes_c)
    wu = _hat_weights(hu_nodes, hu)  # (relays_u, nodes_u)
    # each relay stands for its sub-cell: area in (h_c, h_u) is h_c d(ln h_c) dh_u
    dlc = np.repeat(np.diff(lc) / subgrid, subgrid)
    area_c = hc * dlc
    area_u = np.repeat(np.diff(hu_nodes) / subgrid, subgrid)
    wc, wu = wc * area_c[:, None], wu * area_u[:, None]
    hcg, hug = np.meshgrid(hc, hu, indexing="ij")
    a = (hug + hcg).ravel()
    b = (hug - hcg).ravel()
    # only relays that the largest amplitude of the grid switches (the Preisach triangle
    # a <= H_max, b >= -H_max): the others' state is the record's history, not the loop
    inside = (a <= hc_nodes[-1] * (1.0 + 1e-9)) & (b >= -hc_nodes[-1] * (1.0 + 1e-9))
    mask = inside.reshape(hcg.shape).astype(float)
    total = wc.T @ mask @ wu  # (coercive nodes, interaction nodes)
    return a[inside], b[inside], inside.reshape(hcg.shape), wc, wu, total


def relay_harmonics(up, down, field_amplitude, harmonics=PERIODIC_HARMONICS):
    """Fourier coefficients c_0..c_K of relays in periodic steady state (module docstring).

    Parameters
    ----------
    up, down : arrays
        The relays' switching fields a >= b, [A/m].
    field_amplitude : float
        H_m of H = H_m cos(theta), [A/m].

    Returns
    -------
    array (relays, K + 1), complex
        Output = c_0/2 + Re sum_k c_k e^{j k theta}.

    Examples
    --------
    A relay switching at +-H_m/2 is a square wave between theta = pi/3 and 5 pi/3:
    >>> c = relay_harmonics(np.array([0.5]), np.array([-0.5]), 1.0, 3)
    >>> bool(np.isclose(c[0, 1].real, 4 * np.sin(np.pi / 3) / np.pi))
    True
    """
    a, b = np.asarray(up, float), np.asarray(down, float)
    hm = float(field_amplitude)
    out = np.zeros((a.size, harmonics + 1), complex)
    switches = np.flatnonzero((a <= hm) & (b >= -hm))
    ta = np.arccos(np.clip(a[switches] / hm, -1.0, 1.0))
    tb = np.arccos(np.clip(b[switches] / hm, -1.0, 1.0))
    # one row a harmonic, e^{j k theta} as the k-th power of e^{j theta} (a running product:
    # one complex exponential a relay, not one a harmonic; relative error ~k eps)
    rows = np.empty((harmonics + 1, switches.size), complex)
    # measured from the demagnetised state (module docstring): a relay the drive does not
    # switch holds it (a > H_m ends down, its h_u > 0; b < -H_m ends up, its h_u < 0), 0
    rows[0] = (2.0 * (ta + tb) / math.pi - 2.0
               - 2.0 * demagnetised_state(a[switches], b[switches]))
    ea, eb = np.exp(1j * ta), np.exp(-1j * tb)
    za, zb = ea.copy(), eb.copy()
    for k in range(1, harmonics + 1):
        if k > 1:
            za *= ea
            zb *= eb
        rows[k] = (za - zb) * (2.0 / (1j * math.pi * k))
    out[switches] = rows.T
    return out


def demagnetised_state(up, down):
    """Relays' states after AC demagnetisation: up for h_u = (a + b)/2 < 0, down for
    h_u > 0, 0 on h_u = 0 (a relay there is half up, half down; Mayergoyz 2003, sec. 1.3)."""
    hu = 0.5 * (np.asarray(up, float) + np.asarray(down, float))
    return np.where(hu < 0, 1.0, np.where(hu > 0, -1.0, 0.0))


@functools.lru_cache(maxsize=64)
def _node_harmonics_cached(coercive, interaction, field_amplitude, harmonics):
    # sum_r W[r, n] c(r) with W[(i, j), (n, m)] = wc[i, n] wu[j, m] / total[n, m] over
    # the sub-grid's relays (i, j), those outside the triangle 0: two products
    a, b, inside, wc, wu, total = _relay_grid(coercive, interaction)
    full = np.zeros(inside.shape + (harmonics + 1,), complex)
    full[inside] = relay_harmonics(a, b, field_amplitude, harmonics)
    part = np.swapaxes(full.view(float), 1, 2) @ wu  # (h_c relays, 2 (K + 1), u nodes)
    sums = (wc.T @ part.reshape(part.shape[0], -1)).reshape(wc.shape[1], -1, wu.shape[1])
    out = np.ascontiguousarray(np.swapaxes(sums, 1, 2)).view(complex)
    return (out / np.where(total > 0, total, 1.0)[..., None]).reshape(total.size, -1)


def node_harmonics(coercive, interaction, field_amplitude, harmonics=PERIODIC_HARMONICS):
    """Harmonics (nodes, K + 1) of each node's output R_n at H_m [A/m] (module docstring)."""
    return _node_harmonics_cached(tuple(float(v) for v in coercive),
                                  tuple(float(v) for v in interaction),
                                  float(field_amplitude), int(harmonics))


@functools.lru_cache(maxsize=32)
def _runs_harmonics(coercive, interaction, field_amplitudes):
    """(amplitudes, nodes, 2 (K + 1)) node harmonics at each of several field amplitudes,
    real and imaginary parts interleaved (a real matrix, so that real weights multiply it
    by a real product; cached: the fit asks often)."""
    return np.stack([node_harmonics(coercive, interaction, hm).view(float)
                     for hm in field_amplitudes])


@functools.lru_cache(maxsize=8)
def _synthesis(theta):
    """(cos k theta, sin k theta), k = 1..K, each (K, theta): Re(c e^{j k theta}) is
    Re(c) cos k theta - Im(c) sin k theta."""
    phase = np.outer(np.arange(1, PERIODIC_HARMONICS + 1), np.asarray(theta))
    return np.cos(phase), np.sin(phase)


def _weighted_harmonics(w, harmonics, which):
    """Harmonics (rows, K + 1) of the densities ``w`` (one row of node weights per row, or
    one density for all), row r at the amplitude ``which[r]`` of ``harmonics``
    (:func:`_runs_harmonics`): one real product per amplitude, not one per row (the fit's
    stacked Jacobian repeats each run's amplitude once per weight)."""
    out = np.empty((which.size, harmonics.shape[-1]))
    for u in range(harmonics.shape[0]):
        rows = which == u
        if np.any(rows):
            out[rows] = (w if w.ndim == 1 else w[rows]) @ harmonics[u]
    return out.view(complex)


def synthesise(coefficients, theta):
    """c_0/2 + Re sum_k c_k e^{j k theta} on ``theta``: (rows of c, theta)."""
    c = np.atleast_2d(np.asarray(coefficients))
    k = np.arange(1, c.shape[-1])
    e = np.exp(1j * np.outer(k, np.asarray(theta, float)))
    return np.real(c[:, 1:] @ e) + 0.5 * np.real(c[:, :1])


def _fit_spec(nodes):
    """The unknowns of a density on ``nodes`` nodes: log10 f_r [Hz], q, the node weights."""
    return FitSpec(("log10_rate_frequency_Hz", "rate_exponent")
                   + tuple(f"w{j}" for j in range(nodes)),
                   ((2.5, 2.0) + (0.0,) * nodes,),
                   (0.5, 0.5) + (0.0,) * nodes, (4.5, 4.0) + (math.inf,) * nodes,
                   neutral=(4.5, 4.0) + (0.0,) * nodes)


class PreisachForm(MagnetizationStage, Extension):
    """The Preisach model's output added to the paper's magnetisation (module docstring).

    Memory of the time-stepped form: each relay's state, +1 or -1 (the demagnetised
    state at reset).
    """

    cause = "rate_independent_hysteresis"
    form = "preisach"
    stage = "magnetization"
    signals = "B and y"
    #: a density, first or later, must explain the loop's higher harmonics
    #: (Extension.signature): with its many linear unknowns it can shape a change of the
    #: fundamentals alone, a linear lag of M, which is not hysteresis (labsim's eddy
    #: diffusion with a two-mass resonance, seed 15 at 800 samples a period: beside the
    #: eddy and two-mass forms it took 0.01 % of the paper's excess, its changes to y's and
    #: B's harmonics from the third up within noise, their held-out chi^2 130 -> 154;
    #: answered with hysteresis)
    signature = HIGHER_HARMONICS
    #: The unknowns are the node weights, linear in the model: fitted by the penalised
    #: nonnegative least squares of smeha.diagnose.fit, not one by one.
    linear = True
    #: its output adds to M and does not depend on it (gmt.extensions.steady.stage_adder)
    additive = True
    parameters = (Parameter("rate_frequency_Hz", "Hz", 0.0, math.inf, high_open=False),
                  Parameter("rate_exponent", "-", 0.0, 10.0),
                  Parameter("coercive_fields_A_per_m", "A/m", 0.0, math.inf, is_list=True),
                  Parameter("interaction_fields_A_per_m", "A/m", is_list=True),
                  Parameter("weights_A_per_m", "A/m", 0.0, math.inf, low_open=False,
                            is_list=True))
    #: the density's nodes: (coercive, interaction) grids as (first, last, count)
    grid = (COERCIVE_GRID, INTERACTION_GRID)
    #: the first two unknowns are nonlinear (the rate factor), the rest the node weights
    fit = _fit_spec(COERCIVE_GRID[2] * INTERACTION_GRID[2])
    #: which of the unknowns are linear (the node weights)
    linear_unknowns = slice(2, None)

    @classmethod
    def validate(cls, values):
        hc = values["coercive_fields_A_per_m"]
        hu = values["interaction_fields_A_per_m"]
        w = values["weights_A_per_m"]
        if len(w) != len(hc) * len(hu):
            raise ParameterError(f"{cls.cause} parameter weights_A_per_m has {len(w)} values; "
                                 f"it needs one per node, {len(hc)} x {len(hu)} = "
                                 f"{len(hc) * len(hu)}")
        for name, nodes in (("coercive_fields_A_per_m", hc), ("interaction_fields_A_per_m", hu)):
            if len(nodes) < 2 or np.any(np.diff(nodes) <= 0):
                raise ParameterError(f"{cls.cause} parameter {name} = {list(nodes)} must hold "
                                     "at least two increasing values")

    @classmethod
    def from_fit(cls, x, context):
        hc, hu = node_grid(context["field_max"], *cls.grid)
        return {"rate_frequency_Hz": float(10.0 ** x[0]), "rate_exponent": float(x[1]),
                "coercive_fields_A_per_m": [float(v) for v in hc],
                "interaction_fields_A_per_m": [float(v) for v in hu],
                "weights_A_per_m": [float(v) for v in x[2:]]}

    @classmethod
    def at_bounds(cls, x, tolerance=1e-3):
        # a zero weight is a node without relays, and the upper rate frequency the
        # rate-independent limit, where the exponent no longer acts: neither is a bound
        # pressed on
        names = super().at_bounds(x[:2], tolerance)
        if x[0] >= cls.fit.upper[0] - 0.01:
            return tuple(n for n in names if n not in ("log10_rate_frequency_Hz",
                                                       "rate_exponent"))
        return names

    @classmethod
    def finer_start(cls, x):
        """Unknowns ``x`` carried to :attr:`finer`'s: the rate factor as it is, the node
        weights projected on its grid (:func:`projected_weights`), a start for its fit."""
        lin = cls.linear_unknowns
        return tuple(x[:lin.start]) + tuple(projected_weights(x[lin], cls.grid,
                                                              cls.finer.grid))

    #: Rate factors the diagnosis screens before its alternation (smeha.diagnose.linearfit):
    #: log10 f_r [Hz] and q of a grid over the unknowns' range. Started from one point, the
    #: alternation of weights and rate factor stops where the weights, fitted to one g(f),
    #: hold g there (outside lab data: a score 2.7x worse than g's own optimum).
    RATE_SCREEN = ((1.0, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 4.5), (1.0, 2.0, 3.0, 4.0))

    @classmethod
    def screen_starts(cls):
        """The nonlinear unknowns' grid of :data:`RATE_SCREEN`, one tuple each."""
        return [(a, q) for a in cls.RATE_SCREEN[0] for q in cls.RATE_SCREEN[1]]

    @classmethod
    def output_factor(cls, nonlinear, frequency):
        """The factor the nonlinear unknowns (log10 f_r, q) put on the whole output of a
        run at ``frequency`` [Hz]: g(f), [-] (for the diagnosis' screening)."""
        return cls.rate_factor({"rate_frequency_Hz": 10.0 ** nonlinear[0],
                                "rate_exponent": nonlinear[1]}, frequency)

    @staticmethod
    def rate_factor(values, frequency):
        """g(f) = 1 / (1 + (f/f_r)^q): the share of the population that switches at f, [-]
        (f_r and q may be given per run, :meth:`stack_values`)."""
        fr, q = values["rate_frequency_Hz"], values["rate_exponent"]
        f = np.asarray(frequency, float)
        if np.ndim(fr) or np.ndim(q):
            fr, q = np.asarray(fr, float), np.asarray(q, float)
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.where(np.isinf(fr), 1.0, 1.0 / (1.0 + (f / fr) ** q))
        if math.isinf(fr):
            return np.ones_like(f)
        return 1.0 / (1.0 + (f / fr) ** q)

    @classmethod
    def stack_values(cls, values_list, runs):
        """f_r and q per run, where the copies share the weights and the grid (weights per
        run are a matrix product over the runs, which rounds otherwise than a run's own:
        a copy would not be its own evaluation to the bit; None then)."""
        first = values_list[0]
        keys = ("coercive_fields_A_per_m", "interaction_fields_A_per_m", "weights_A_per_m")
        if any(v[k] != first[k] for v in values_list for k in keys):
            return None
        out = dict(first)
        for key in ("rate_frequency_Hz", "rate_exponent"):
            out[key] = np.repeat(np.array([v[key] for v in values_list], float), runs)
        return out

    @classmethod
    def smoothness(cls):
        """Second differences of the node weights along each axis of the form's grid: the
        penalty's matrix."""
        nc, nu = cls.grid[0][2], cls.grid[1][2]
        rows = []
        for i in range(nc):
            for j in range(nu):
                if 0 < i < nc - 1:
                    rows.append({(i - 1) * nu + j: 1.0, i * nu + j: -2.0, (i + 1) * nu + j: 1.0})
                if 0 < j < nu - 1:
                    rows.append({i * nu + j - 1: 1.0, i * nu + j: -2.0, i * nu + j + 1: 1.0})
        d = np.zeros((len(rows), nc * nu))
        for r, row in enumerate(rows):
            for c, v in row.items():
                d[r, c] = v
        return d

    # periodic form
    @classmethod
    def periodic_output(cls, values, field_amplitudes, theta, frequencies=0.0, phases=0.0):
        """M_P over ``theta`` for each H_m (and f, [Hz]), (runs, theta), [A/m]; the field
        H_m cos(theta + phase) (``phases`` [rad], one per run or one for all)."""
        w = np.asarray(values["weights_A_per_m"], float)
        hc = tuple(float(v) for v in values["coercive_fields_A_per_m"])
        hu = tuple(float(v) for v in values["interaction_fields_A_per_m"])
        hms = np.atleast_1d(np.asarray(field_amplitudes, float))
        g = np.broadcast_to(cls.rate_factor(values, frequencies), hms.shape)
        # weights of one density, or one row per run (the fit's stacked Jacobian)
        amplitudes, which = np.unique(hms, return_inverse=True)
        coeff = g[:, None] * _weighted_harmonics(
            w, _runs_harmonics(hc, hu, tuple(amplitudes)), which.ravel())
        if np.any(phases):
            k = np.arange(coeff.shape[-1])
            coeff = coeff * np.exp(1j * np.multiply.outer(
                np.broadcast_to(np.asarray(phases, float), hms.shape).ravel(), k))
        cos, sin = _synthesis(tuple(np.asarray(theta, float)))
        return coeff[:, 1:].real @ cos - coeff[:, 1:].imag @ sin + 0.5 * coeff[:, :1].real

    @classmethod
    def steady_output(cls, values, steady, magnetization, theta, memo=None):
        if memo is not None and "output" in memo:
            return magnetization + memo["output"]
        sw = steady.switching_gain  # the field stage's (Extension.switching_gain)
        out = cls.periodic_output(values, np.abs(sw) * steady.field_amplitude, theta,
                                  steady.frequency, np.angle(sw))
        if np.ndim(steady.field_amplitude) == 0:
            out = out[0]
        if memo is not None:
            memo["output"] = out
        return magnetization + out

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        hc = tuple(values["coercive_fields_A_per_m"])
        hu = tuple(values["interaction_fields_A_per_m"])
        self.up, self.down, weight = _relays(hc, hu)
        # the rate factor at the operating point's frequency (module docstring)
        self.relay_weights = (weight @ np.asarray(values["weights_A_per_m"], float)
                              * float(self.rate_factor(values, point.frequency)))
        self.states = self._demagnetised()
        # M_P is measured from the demagnetised state (module docstring)
        self.rest = float(self.relay_weights @ self.states)

    def _demagnetised(self):
        return demagnetised_state(self.up, self.down)

    def adjust(self, mag, step, time):
        h = self.switching_field(mag)
        self.states = np.where(h >= self.up, 1.0, np.where(h <= self.down, -1.0, self.states))
        return self.with_magnetization(mag, float(self.relay_weights @ self.states) - self.rest)

    def waveform(self, theta, upstream):
        sw = self.point_switching_gain
        return upstream(theta) + self.periodic_output(
            self.values, abs(sw) * self.point.field_amplitude, theta, self.point.frequency,
            np.angle(sw))[0]

    def reset(self, rest_displacement):
        self.states = self._demagnetised()

    def get_state(self):
        return tuple(float(s) for s in self.states)

    def set_state(self, state):
        if len(state) != len(self.states):
            raise ParameterError(f"{self.cause} state has {len(state)} values; the model has "
                                 f"{len(self.states)} relays")
        self.states = np.array(state, dtype=float)


class FinerPreisachForm(PreisachForm):
    """The same density on :data:`FINER_GRID`: not a candidate of its own, but the check
    of the diagnosis behind a later cause that acts on the magnetisation beside the density
    (:mod:`smeha.diagnose.resolution`). Its variants are those of :class:`PreisachForm`
    (the nodes travel with the weights)."""

    grid = FINER_GRID
    fit = _fit_spec(FINER_GRID[0][2] * FINER_GRID[1][2])
    finer = None


PreisachForm.finer = FinerPreisachForm
