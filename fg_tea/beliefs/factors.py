"""Factor families of the belief graph, as named tables over discrete variables.

Variables are named, never bare ints: ``L[mug]`` is the site where the mug stood when the episode
began (cardinality K = number of sites); ``kettle.contains_water`` is a Bernoulli task state
(index 0 = false, 1 = true). A :class:`Factor` is a non-negative table whose axes follow its
variable tuple (C order, first variable most significant — gtsam's convention too).

Constructors, with the docs/design.md equations they realise:

- :func:`location_prior` — q0(L_o = i) ∝ max(a_ic, eps)                                     [2]
- :func:`miss_factor` — P(not seen at j | L_o = i) = mu if i = j else 1                    [5, 6]
- :func:`detection_factor` — P(seen at j | L_o = i) = 1 - mu if i = j else fp
- :func:`collapse_factor` — soft evidence whose posterior marginal is eq. [4] exactly
- :func:`state_prior`, :func:`state_observation` — Bernoulli prior, noisy sensor          [23, 24]
- :func:`effect_factor` — one effect of P(z' | z, a), or the direct form q'(z) = rho  [27; 25, 26]
- :func:`capacity_factor`, :func:`pair_factor` — relational factors of joint models
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from fg_tea.common.errors import ContradictionError


@dataclass(frozen=True, eq=False)
class Factor:
    """A non-negative table over named discrete variables.

    Args:
        variables: variable names, one per axis of `table`.
        table: array of shape (card(v) for v in variables), values >= 0.
        label: what the factor represents, for logs and inspection.
    """

    variables: tuple[str, ...]
    table: np.ndarray
    label: str = ""
    #: Optional natural logarithm of the table up to an additive constant (-inf where the table
    #: is zero), for factors whose exact values do not fit a float64 table (e.g. eq. 4's collapse
    #: after a thousand misses). When given, it is the factor's exact value; `table` is
    #: ``exp(log_table - max)``.
    log_table: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.table.ndim != len(self.variables):
            raise ValueError(f"factor {self.label!r}: table has {self.table.ndim} axes for "
                             f"{len(self.variables)} variables")
        if len(set(self.variables)) != len(self.variables):
            raise ValueError(f"factor {self.label!r}: repeated variable in {self.variables}")
        if not np.all(np.isfinite(self.table)) or np.any(self.table < 0):
            raise ValueError(f"factor {self.label!r}: table must be finite and non-negative")

    def log_values(self) -> np.ndarray:
        """The factor's natural log (exact when built in log space; -inf where it is zero)."""
        if self.log_table is not None:
            return np.asarray(self.log_table, dtype=float)
        with np.errstate(divide="ignore"):
            return np.log(self.table)


@dataclass(frozen=True, eq=False)
class Evidence(Factor):
    """Every piece of unary evidence on one variable, merged into one factor in log space.

    Repeated observations of one variable (state readings [23, 24], misses [5, 6], detections
    [4]) multiply; holding their product as one factor keeps the graph's size bounded whatever
    the number of observations (dense contraction has an operand limit), and holding it as a sum
    of logs keeps it exact where the product would underflow (465 alternating readings, or a
    thousand misses at one site). ``log_table`` is the exact sum of the merged factors' logs,
    ``table`` its exponential shifted so that its maximum is 1 (a constant factor changes no
    posterior).

    Attributes:
        count: how many factors were merged.
        kinds: how many of each kind (the first word of their labels: ``miss``, ``observe``...).
    """

    count: int = 0
    kinds: tuple[tuple[str, int], ...] = ()

    def kind_count(self, kind: str) -> int:
        """How many merged factors were of `kind` (``"miss"``, ``"collapse"``, ``"observe"``)."""
        return dict(self.kinds).get(kind, 0)


def merge_evidence(existing: Evidence | None, factor: Factor) -> Evidence:
    """`existing` times `factor` (both unary on one variable), summed in log space.

    Raises:
        ContradictionError: the product is zero everywhere (the evidence contradicts itself).
        ValueError: the factor is not unary, or names another variable.
    """
    if len(factor.variables) != 1:
        raise ValueError(f"only unary evidence can be merged, got {factor.label!r}")
    var = factor.variables[0]
    if existing is not None and existing.variables != factor.variables:
        raise ValueError(f"evidence on {existing.variables[0]!r} cannot absorb {factor.label!r}")
    add = factor.log_values()
    total = add if existing is None else np.asarray(existing.log_table, dtype=float) + add
    top = float(np.max(total))
    if not np.isfinite(top):
        raise ContradictionError(f"evidence {factor.label} has probability zero under the model")
    kind = factor.label.split(" ", 1)[0] or "factor"
    kinds = dict(existing.kinds) if existing is not None else {}
    kinds[kind] = kinds.get(kind, 0) + 1
    count = (existing.count if existing is not None else 0) + 1
    summary = ", ".join(f"{k} x{n}" for k, n in sorted(kinds.items()))
    return Evidence((var,), np.exp(total - top), f"evidence {var} ({summary})", total, count,
                    tuple(sorted(kinds.items())))


def location_var(obj: str) -> str:
    """The name of object `obj`'s location variable."""
    return f"L[{obj}]"


def location_prior(obj: str, weights: np.ndarray, floor: float) -> Factor:
    """Eq. 2: q0(L_o = i) = max(a_i, eps) / sum_k max(a_k, eps)."""
    table = np.maximum(np.asarray(weights, dtype=float), floor)
    return Factor((location_var(obj),), table / table.sum(), f"prior {location_var(obj)}")


def miss_factor(obj: str, site_index: int, n_sites: int, mu: float) -> Factor:
    """Eq. 5: the likelihood of 'looked at site j and did not see o'."""
    table = np.ones(n_sites)
    table[site_index] = mu
    return Factor((location_var(obj),), table, f"miss {location_var(obj)}@{site_index}")


def view_miss_factor(obj: str, sites: tuple[int, ...], miss: np.ndarray, n_sites: int,
                     label: str) -> Factor:
    """"o not seen in a look covering `sites`": l(a) = miss[c] at the c-th in-view site a, 1
    elsewhere (eqs. 5-6 over every site in view; docs/design.md eq. 30)."""
    table = np.ones(n_sites)
    table[list(sites)] = miss
    return Factor((location_var(obj),), table, f"miss {location_var(obj)}@{label}")


def detection_factor(obj: str, site_index: int, n_sites: int, mu: float, fp: float) -> Factor:
    """The likelihood of 'seen at site j': 1 - mu at j, false-positive rate fp elsewhere."""
    table = np.full(n_sites, fp)
    table[site_index] = 1.0 - mu
    return Factor((location_var(obj),), table, f"detect {location_var(obj)}@{site_index}")


def collapse_target(site_index: int, n_sites: int, floor: float) -> np.ndarray:
    """Eq. 4: q+(L_o = i) ∝ 1 if i = j else eps."""
    target = np.full(n_sites, floor)
    target[site_index] = 1.0
    return target / target.sum()


def collapse_factor(obj: str, site_index: int, current: np.ndarray, floor: float,
                    log_current: np.ndarray | None = None) -> Factor:
    """Soft evidence that sets q(L_o) to eq. 4 exactly (Jeffrey's rule as a factor).

    Multiplying the graph by lambda(i) = t(i) / q(L_o = i) makes the posterior marginal of L_o
    equal t (the collapse of docs/design.md eq. (4); this factor is eq. (32)) and moves every
    correlated variable by P(x | L_o = i)
    weighted with t — the exact joint counterpart of eq. 4. Sites the belief already rules out
    (q = 0, possible only with zero-probability factors) stay ruled out: lambda = 0 there, so the
    posterior is t restricted to the support of q.

    The ratio is formed in log space, log lambda = log t - log q, and stored exactly in
    ``log_table`` (``table`` is its exponential scaled to a maximum of 1): after a few hundred
    misses at site j, q(L_o = j) is below the smallest normal float and t / q overflows.

    Args:
        obj: the detected object.
        site_index: the site j it was seen at.
        current: q(L_o) now.
        floor: eq. 4's floor eps.
        log_current: log q(L_o) now, exact, when the caller has it (it takes precedence over
            `current`, whose smallest entries may have underflowed to zero).

    Raises:
        ContradictionError: q(L_o = j) = 0 — the detection contradicts the belief.
    """
    current = np.asarray(current, dtype=float)
    if log_current is None:
        with np.errstate(divide="ignore"):
            log_current = np.log(current)
    log_current = np.asarray(log_current, dtype=float)
    if not log_current[site_index] > -np.inf:
        raise ContradictionError(f"{location_var(obj)} was detected at site {site_index}, where its "
                                 "probability is zero")
    target = collapse_target(site_index, len(log_current), floor)
    support = np.isfinite(log_current)
    log_ratio = np.full(len(log_current), -np.inf)
    log_ratio[support] = np.log(target[support]) - log_current[support]
    table = np.exp(log_ratio - np.max(log_ratio))
    return Factor((location_var(obj),), table, f"collapse {location_var(obj)}@{site_index}",
                  log_ratio)


def state_prior(state: str, p_true: float) -> Factor:
    """Bernoulli prior q(z = 1) = p (eq. 21)."""
    return Factor((state,), np.array([1.0 - p_true, p_true]), f"prior {state}")


def state_observation(state: str, value: bool, sensitivity: float, specificity: float) -> Factor:
    """Eqs. 23-24: P(o | z) with sensitivity alpha = P(o=1|z=1), specificity beta = P(o=0|z=0)."""
    if value:
        table = np.array([1.0 - specificity, sensitivity])
    else:
        table = np.array([specificity, 1.0 - sensitivity])
    return Factor((state,), table, f"observe {state}={int(value)}")


def effect_factor(target_new: str, target_old: str, requires_old: tuple[str, ...], value: bool,
                  success: float, direct: bool) -> Factor:
    """One effect of an action as a conditional table P(z'_t | z_t, requires).

    Full form (eq. 27): if every required state holds, z'_t = value with probability `success`
    and keeps its previous value otherwise; if a requirement fails, z'_t = z_t.
    Direct form (eqs. 25-26): q'(z_t = value) = success whatever the previous state.
    """
    v = int(value)
    if direct:
        table = np.empty(2)
        table[v], table[1 - v] = success, 1.0 - success
        return Factor((target_new,), table, f"effect {target_new} (direct)")
    parents = (target_old,) + tuple(r for r in requires_old if r != target_old)
    table = np.zeros((2,) * len(parents) + (2,))
    for assignment in itertools.product((0, 1), repeat=len(parents)):
        old = assignment[0]
        if all(assignment[1:]) and (target_old not in requires_old or old == 1):
            table[assignment + (v,)] += success
            table[assignment + (old,)] += 1.0 - success
        else:
            table[assignment + (old,)] = 1.0
    return Factor(parents + (target_new,), table, f"effect {target_new}")


def pair_factor(obj_a: str, obj_b: str, same_site: float, same_room: float,
                rooms: list[str], label: str) -> Factor:
    """psi(L_a, L_b): x`same_site` on one site, x`same_room` on two sites of one room, else 1."""
    k = len(rooms)
    room = np.array([[rooms[i] == rooms[j] for j in range(k)] for i in range(k)])
    table = np.where(room, same_room, 1.0)
    np.fill_diagonal(table, same_site)
    return Factor((location_var(obj_a), location_var(obj_b)), table, label)


def capacity_factor(objects: list[str], capacities: list[int | None], penalty: float) -> Factor | None:
    """Site capacity: each object beyond a site's capacity multiplies by `penalty`.

    A factor over every location variable (one table of K^N entries); None when no site has a
    capacity that N objects could exceed.
    """
    n, k = len(objects), len(capacities)
    limited = [(j, c) for j, c in enumerate(capacities) if c is not None and c < n]
    if not limited:
        return None
    table = np.ones((k,) * n)
    for j, c in limited:
        count = np.zeros((k,) * n, dtype=np.int16)
        for axis in range(n):
            shape = [1] * n
            shape[axis] = k
            count += (np.arange(k) == j).reshape(shape).astype(np.int16)
        excess = np.maximum(count - c, 0)
        table *= np.where(excess > 0, float(penalty) ** excess.astype(float), 1.0)
    return Factor(tuple(location_var(o) for o in objects), table, "capacity")


def log_ratio_gap(now: np.ndarray, target: np.ndarray) -> float:
    """max |log(now / target)| over the entries the target gives mass (inf if `now` puts mass
    where the target has none, or none where it has some)."""
    mass = target > 0
    if np.any(now[~mass] > 0):
        return math.inf
    if np.any(now[mass] <= 0):
        return math.inf
    return float(np.max(np.abs(np.log(now[mass]) - np.log(target[mass])))) if mass.any() else 0.0


def as_evidence(factor: Factor) -> Evidence:
    """`factor`, known to be the merged :class:`Evidence` of its variable, typed as such."""
    assert isinstance(factor, Evidence)
    return factor
