"""The learned route's feature families and the physical family each one reads as.

The learned loop screens online features (``models/feature_library.py``) grouped by their
``Augmentation.family`` (a command delay's lags and increments, Coulomb friction's rate signs,
...). A :class:`LearnedFamily` subclass names the feature classes of one such family, the
physical family (:mod:`.base`) it reads as in a report's ``physical`` block, and how the loop
picks the member that states the family's parameters. :func:`register_learned` puts one
instance under the features' family name in :data:`LEARNED_FAMILIES`; :func:`learned_family`
answers for any feature family, a family not registered reading as ``other``. The learned loop
and its report read these attributes and methods, never a family's name.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar, Mapping, Sequence

import numpy as np

from ...models import feature_library as fl
from ...models.feature_base import Augmentation
from .base import Family
from .body import OdomForce
from .joints import (Backlash, CommandDelay, CommandFilter, JointFrictionFamily, TimeDrift,
                     TorqueSaturation)
from .legs import ContactPhase

if TYPE_CHECKING:
    from ..selection import CandidateScore

__all__ = ["LearnedFamily", "LEARNED_FAMILIES", "register_learned", "learned_family",
           "DELAY_TOLERANCE", "PLANE_R2", "PLANE_MIN_SPREAD_M", "floor_plane", "slope_reading",
           "physical_reading"]

# Members whose total held-out gain is within this fraction of the best one's count as equal.
DELAY_TOLERANCE = 0.1
MS_PER_STEP = 10.0   # one control step [ms]


class LearnedFamily:
    """One family of the learned loop's candidate features.

    ``features``: its feature classes (all of one ``Augmentation.family``); ``reads_as``: the
    physical family class it reads as (None: ``other``); ``parameter``: the name of the
    parameter the report states (default: the physical family's primary, ``value`` for
    ``other``); ``scans_delay``: its members are command lags whose delay the replacement scan
    estimates (``selection.py``, step 5); ``single_joints``: the rollout route narrows a kept
    leg, joint type or side to one joint where that joint carries the gain (False where the
    physical family acts on a whole leg); ``excitation_shows``: its columns are the joints' own
    response to their commands and states (their history, or a nonlinear function of them),
    which command excitation probes and a gait alone hardly does, so a recording with excitation
    gains from them more than one without for any robot (decision 031: a reference recorded
    under another excitation cannot contrast them); ``scoped_by_columns``: each of its columns
    belongs to one joint and does not depend on the others (a member at a narrower joint group
    has a subset of the full member's columns), so the one-step loop scopes a detected member
    by scoring those subsets (``selection.py``, step 5; decision 065).
    """

    features: ClassVar[tuple[type[Augmentation], ...]] = ()
    reads_as: ClassVar[type[Family] | None] = None
    parameter: ClassVar[str] = ""
    scans_delay: ClassVar[bool] = False
    single_joints: ClassVar[bool] = True
    excitation_shows: ClassVar[bool] = False
    scoped_by_columns: ClassVar[bool] = False

    @property
    def name(self) -> str:
        return self.features[0].family if self.features else ""

    @property
    def vocabulary(self) -> str:
        """The physical family's vocabulary name, or ``other``."""
        p = self.reads_as
        return "other" if p is None else (p.reported_as or p.name)

    @property
    def acts_on_joints(self) -> bool:
        """Whether its features' joint group is a joint scope (else it reads as ``body``)."""
        return self.reads_as is not None and self.reads_as.kind == "joints"

    @property
    def report_parameter(self) -> str:
        if self.parameter:
            return self.parameter
        return "value" if self.reads_as is None else self.reads_as.primary

    def magnitude(self, aug: Augmentation) -> float | None:
        """The physical magnitude a member states (None: the features measure none)."""
        return None

    def estimate_member(self, scores: Sequence["CandidateScore"],
                        tolerance: float = DELAY_TOLERANCE) -> "CandidateScore":
        """The member that states the family's parameters (parsimony): of the members within
        ``tolerance`` of the best total gain, the one with the fewest columns (then the larger
        gain), so friction on the knees is named "knees" rather than "all joints" when the
        other joints add nothing."""
        best = max(s.total_gain for s in scores)
        if best <= 0:
            return max(scores, key=lambda s: s.total_gain)
        ok = [s for s in scores if s.total_gain >= (1.0 - tolerance) * best]
        return min(ok, key=lambda s: (len(s.augmentation.columns()), -s.total_gain))


DELAY_SCOPE_ALPHA = 0.01


def delay_scope(lags: Sequence["CandidateScore"], alpha: float = DELAY_SCOPE_ALPHA) -> str:
    """The joints a command delay is scoped to: where the gain of the command-lag members
    ``lags`` lands. In a trot the legs' set-points are nearly linear in one another (a diagonal
    pair moves together), so any side's or leg's u_(t-k) also carries a delayed side's old
    command, and the members' total gains cannot tell the scope; the joints whose own q and dq
    the lags improve can. Of the best all-joint member's per-element gains, each narrower scope
    screened (``candidates.DELAY_SCOPES`` by default): its q and dq elements against every
    other joint's, one-sided Mann-Whitney, times the number of those scopes; the scope with
    the smallest p below ``alpha``, else all joints (a one-side delay:
    ``benchmarks/blind_zoo/zoos/zoo12/runs/run2_delay_scope_widen/README.md``, z04)."""
    from scipy.stats import mannwhitneyu

    from ...models.feature_library import JOINT_GROUPS, JOINT_NAMES
    from ..learned import _joint_elements
    full = [s for s in lags if s.augmentation.joints == "all"]
    if not full or len(full) == len(lags):     # no narrower scope was screened
        return "all"
    gain = np.asarray(max(full, key=lambda s: s.total_gain).gain, dtype=float)
    scopes = sorted({s.augmentation.joints for s in lags} - {"all"})   # those screened
    best, best_p = "all", alpha
    for scope in scopes:
        inside = set(JOINT_GROUPS[scope])
        rest = [j for j in range(len(JOINT_NAMES)) if j not in inside]
        p = float(mannwhitneyu(gain[_joint_elements(sorted(inside))],
                               gain[_joint_elements(rest)], alternative="greater").pvalue
                  ) * len(scopes)
        if p < best_p:
            best, best_p = scope, p
    return best


LEARNED_FAMILIES: dict[str, LearnedFamily] = {}


def register_learned(cls: type[LearnedFamily]) -> type[LearnedFamily]:
    """Register one instance of ``cls`` under its features' family name (a decorator)."""
    names = {f.family for f in cls.features}
    if len(names) != 1:
        raise ValueError(f"{cls.__name__}: features must share one family, not {sorted(names)}")
    name = names.pop()
    old = LEARNED_FAMILIES.get(name)
    if old is not None and type(old) is not cls:
        raise ValueError(f"learned family {name!r} is already registered to "
                         f"{type(old).__name__}")
    LEARNED_FAMILIES[name] = cls()
    return cls


def learned_family(name: str) -> LearnedFamily:
    """The registered learned family of a feature family name; an unregistered one reads as
    ``other`` and picks its member by parsimony."""
    return LEARNED_FAMILIES.get(name) or LearnedFamily()


@register_learned
class CommandDelayFeatures(LearnedFamily):
    """u_{t-k} and its increments: a late set-point."""

    features = (fl.CommandLag, fl.CommandIncrement)
    reads_as = CommandDelay
    excitation_shows = True
    scans_delay = True

    def magnitude(self, aug: Augmentation) -> float | None:
        return MS_PER_STEP * aug.params()["lag"] if isinstance(aug, fl.CommandLag) else None

    def estimate_member(self, scores: Sequence["CandidateScore"],
                        tolerance: float = DELAY_TOLERANCE) -> "CandidateScore":
        """Next to u_t, any u_{t-k} with k <= d lets the model rebuild u_{t-d} by inter-/
        extrapolating with u_t, while k > d only repeats what the state already shows, so the
        held-out gain of u_{t-k} is about flat up to the delay and drops after it. The estimate
        is the largest k whose total gain is within ``tolerance`` of the best lag's (the knee of
        the profile), not the argmax, which is a coin toss between 1 and d; without a lag with
        a positive gain, parsimony as for any family. The lags compared are those of the scope
        :func:`delay_scope` reads off where the gain lands (all of them where that scope has
        no lag with a positive gain)."""
        lags = [s for s in scores if isinstance(s.augmentation, fl.CommandLag)]
        if lags:
            best = max(s.total_gain for s in lags)
            if best > 0:
                scope = delay_scope(lags)
                within = [s for s in lags if s.augmentation.joints == scope]
                if not within or max(s.total_gain for s in within) <= 0:
                    within = lags
                top = max(s.total_gain for s in within)
                ok = [s for s in within if s.total_gain >= (1.0 - tolerance) * top]
                return max(ok, key=lambda s: s.augmentation.lag)
        return super().estimate_member(scores, tolerance)


@register_learned
class CommandFilterFeatures(LearnedFamily):
    """The set-point through a first-order low-pass."""

    features = (fl.CommandFilter,)
    reads_as = CommandFilter
    excitation_shows = True

    def magnitude(self, aug: Augmentation) -> float | None:
        return aug.params()["time_constant_ms"]


@register_learned
class CoulombFeatures(LearnedFamily):
    features = (fl.JointRateSign,)
    reads_as = JointFrictionFamily
    excitation_shows = True


@register_learned
class PlayFeatures(LearnedFamily):
    """The command's or angle's position in a play band: backlash of the band's width."""

    features = (fl.Play,)
    reads_as = Backlash
    excitation_shows = True
    scoped_by_columns = True

    def magnitude(self, aug: Augmentation) -> float | None:
        return aug.params()["width"]


@register_learned
class SaturationFeatures(LearnedFamily):
    features = (fl.TrackingSaturation,)
    reads_as = TorqueSaturation
    excitation_shows = True
    parameter = "torque_limit_Nm"


@register_learned
class StateLagFeatures(LearnedFamily):
    """Earlier states: dynamics of a higher order than the model's, a filter or a lag."""

    features = (fl.StateLag,)
    excitation_shows = True


@register_learned
class RateMagnitudeFeatures(LearnedFamily):
    features = (fl.JointRateMagnitude,)
    excitation_shows = True


@register_learned
class HeadingFeatures(LearnedFamily):
    features = (fl.Heading,)
    reads_as = OdomForce


@register_learned
class ElapsedTimeFeatures(LearnedFamily):
    features = (fl.ElapsedTime,)
    reads_as = TimeDrift


@register_learned
class FootContactFeatures(LearnedFamily):
    features = (fl.FootHeight, fl.CommandedLift)
    reads_as = ContactPhase
    parameter = "magnitude"


@register_learned
class SwingFeatures(LearnedFamily):
    """A joint's rate while its foot swings (:class:`~...models.feature_library.SwingRate`):
    a force or damping on a swinging foot, scoped by the joints whose columns carry it (one
    leg's three joints read as that leg)."""

    features = (fl.SwingRate,)
    reads_as = ContactPhase
    parameter = "magnitude"
    single_joints = False

    @property
    def acts_on_joints(self) -> bool:
        return True


@register_learned
class GaitPhaseFeatures(LearnedFamily):
    features = (fl.GaitPhase,)
    reads_as = ContactPhase
    parameter = "magnitude"


# A position effect reads as an inclined floor when a plane through the measured body heights
# explains at least this share of their variance over the floor.
PLANE_R2 = 0.5
# ... and when the positions spread at least this far [m] (standard deviation) across their
# narrowest direction, so that the plane's tilt is measured in both directions.
PLANE_MIN_SPREAD_M = 0.02


def floor_plane(recs: Sequence[Any]) -> dict[str, Any] | None:
    """The floor under the recordings as a plane: the body height z_w fitted by least squares as
    a + g . (x_w, y_w) over every measurement of ``recs`` (odometry level in the world, so a
    floor inclined in the world lifts the body as it walks uphill). {slope_deg,
    uphill_direction_deg (odom), rise_per_m (|g|), r2 (the share of z_w's variance the plane
    explains), n_samples}; None with fewer than 3 measurements, or positions that spread less
    than :data:`PLANE_MIN_SPREAD_M` across their narrowest direction (along a line the tilt
    across it is not measured)."""
    if not recs:
        return None
    P = np.vstack([np.asarray(r.position, dtype=np.float64) for r in recs])
    P = P[np.all(np.isfinite(P), axis=1)]
    if P.shape[0] < 3:
        return None
    XY = P[:, :2] - P[:, :2].mean(axis=0)
    if np.linalg.svd(XY, compute_uv=False)[-1] / math.sqrt(P.shape[0]) < PLANE_MIN_SPREAD_M:
        return None
    A = np.column_stack([np.ones(P.shape[0]), XY])
    coef, *_ = np.linalg.lstsq(A, P[:, 2], rcond=None)
    var = float(P[:, 2].var())
    r2 = 0.0 if var <= 0 else float(1.0 - (P[:, 2] - A @ coef).var() / var)
    g = coef[1:]
    return {"slope_deg": math.degrees(math.atan(math.hypot(*g))),
            "uphill_direction_deg": math.degrees(math.atan2(g[1], g[0])) % 360.0,
            "rise_per_m": float(math.hypot(*g)), "r2": r2, "n_samples": int(P.shape[0])}


#: starts closer than this (the SD of the moves' first (x, y) [m], and of their first heading
#: [rad]) leave a move's position a function of its type and elapsed time
START_SPREAD_M = 0.05
START_SPREAD_RAD = 0.1


def start_spread(recs: Sequence[Any]) -> dict[str, Any]:
    """How far apart the moves start: the SD over moves of the first (x, y) (the larger axis)
    and of the first heading (circular). ``confounded``: both below :data:`START_SPREAD_M` and
    :data:`START_SPREAD_RAD`, so that where a move is follows from its type and elapsed time
    and a position effect cannot be told from one of the move's progress."""
    from ...rotations import quat_to_rpy
    if len(recs) < 2:
        return {"xy_sd_m": 0.0, "heading_sd_rad": 0.0, "confounded": True}
    xy = np.array([np.asarray(r.position[0], float)[:2] for r in recs])
    yaw = np.array([float(quat_to_rpy(np.asarray(r.orientation[0], float))[2]) for r in recs])
    r_len = float(np.hypot(np.mean(np.cos(yaw)), np.mean(np.sin(yaw))))
    yaw_sd = float(np.sqrt(max(-2.0 * np.log(max(r_len, 1e-12)), 0.0)))
    xy_sd = float(np.max(np.std(xy, axis=0)))
    return {"xy_sd_m": xy_sd, "heading_sd_rad": yaw_sd,
            "confounded": bool(xy_sd < START_SPREAD_M and yaw_sd < START_SPREAD_RAD)}


def slope_reading(floor: Mapping[str, Any] | None) -> dict[str, Any] | None:
    """A position effect's reading as an inclined floor (the vocabulary's ``ground_slope``)
    when ``floor`` (:func:`floor_plane`) explains at least :data:`PLANE_R2` of the body height's
    variance; else None."""
    if not floor or floor.get("r2", 0.0) < PLANE_R2:
        return None
    return {"family": "ground_slope", "scope": "body",
            "params": {"slope_deg": floor["slope_deg"],
                       "uphill_direction_deg": floor["uphill_direction_deg"],
                       "odom": "level in the world"},
            "statement": (f"the floor rises about {100 * floor['rise_per_m']:.1f} cm per metre "
                          f"towards {floor['uphill_direction_deg']:.0f} deg in odom: inclined by "
                          f"about {floor['slope_deg']:.1f} deg (a plane through the measured "
                          f"body heights explains {floor['r2']:.0%} of their variation over "
                          f"the floor)")}


def physical_reading(aug: Augmentation, floor: Mapping[str, Any] | None = None
                     ) -> dict[str, Any]:
    """The vocabulary's family, scope and parameter of a feature the learned loop added
    (report.json's ``effects[i].physical``): the loop measures no physical magnitude, so the
    parameter is null except a command delay's (lag x 10 ms), a command filter's, play's width,
    and a position effect's where the recordings' floor is a plane (``floor``,
    :func:`floor_plane`; :func:`slope_reading`): an inclined floor."""
    from .scopes import group_scope
    if aug.family == "pose (position)":
        slope = slope_reading(floor)
        if slope is not None:
            return slope
    fam = learned_family(aug.family)
    params = aug.params()
    scope = group_scope(params.get("joints", "all")) if fam.acts_on_joints else "body"
    return {"family": fam.vocabulary, "scope": scope,
            "params": {fam.report_parameter: fam.magnitude(aug)},
            "statement": f"the learned model lacked {aug.label()} ({aug.family})"}
