"""The estimator registry: every vision estimator, by name, in one place.

Planar estimators (joint angles, `Estimator`) and spatial ones (the arm in 3-D,
`SpatialEstimator`, entries with ``spatial=True``) share it; each follows only clips of
its own kind (`EstimatorEntry.unsupported`): `build_estimator` builds the former,
`build_spatial_estimator` the latter.

An entry knows how to build its estimator from an `EstimatorContext` (what the env
publishes: fps, links, joint ranges, reference direction, modality, robot model), which
clips it can follow, which keyword parameters a user may pass it, and how many frames it
reads before its first real estimate. The env wrapper (`wrappers.RegistryObservation`),
the evaluation suite, `imimic eval`, `imimic mimic` and the CLI's choices all read this
registry; adding an estimator is one `register` call::

    register(EstimatorEntry("mine", "my estimator", lambda context, **p: Mine(context.fps)))
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from imimic_gym.estimators.don.config import (
    DONConfig,
    LinkedDONConfig,
    don_preset,
    linked_don_preset,
    override,
)
from imimic_gym.estimators.types import (
    Estimate,
    Estimator,
    EstimatorContext,
    SpatialEstimator,
)

__all__ = [
    "ESTIMATORS", "EstimatorEntry", "UnsupportedClipError", "build_estimator",
    "build_spatial_estimator", "get_estimator", "register", "unregister",
]


class UnsupportedClipError(ValueError):
    """An estimator was asked to follow a clip it cannot (too many links, another
    demonstrator, no truth for the oracle)."""


def _one_frame(params: Mapping[str, Any]) -> int:
    return 1


@dataclass(frozen=True)
class EstimatorEntry:
    """One registered estimator.

    Attributes:
        name: the registry key (``--estimator NAME``).
        summary: one line for ``--help`` and the demo's introduction.
        build: ``build(context, **params) -> Estimator`` (``-> SpatialEstimator`` for a
            spatial one).
        links: the numbers of moving links it follows.
        demonstrators: the demonstrators it can read (None: any).
        params: keyword parameters a user may pass to ``build``.
        frames_needed: ``frames_needed(params)``: frames read before its first real
            estimate (a clip shorter than that gives it nothing to say).
        needs_truth: reads the clip's truth, not its pixels (the oracle).
        real_people: made for footage of real people: `imimic mimic` gives its robot a
            human arm's joint ranges (`pose.human_joint_ranges`) unless told otherwise.
        photos: reads each frame alone, so it can score single photos (`imimic eval
            --photos`); the frame-differencing estimators need a video.
        spatial: reads the arm in 3-D (an `ArmPose` per frame) and follows only spatial
            clips (`EstimatorContext.spatial`); ``links`` does not apply to it. The oracle
            (``needs_truth``) reads whatever truth the env gives, on either kind.
    """

    name: str
    summary: str
    build: Callable[..., Any]
    links: tuple[int, ...] = (1,)
    demonstrators: tuple[str, ...] | None = None
    params: tuple[str, ...] = ()
    frames_needed: Callable[[Mapping[str, Any]], int] = field(default=_one_frame)
    needs_truth: bool = False
    real_people: bool = False
    photos: bool = False
    spatial: bool = False

    @property
    def links_text(self) -> str:
        """The links it follows in words: "one moving link", "1 to 3 moving links"."""
        return _numbers(self.links)

    def unsupported(self, context: EstimatorContext) -> str | None:
        """Why this estimator cannot follow a clip of ``context``, or None if it can."""
        if self.spatial and not context.spatial:
            return (f"estimator {self.name!r} reads the arm in 3-D; this clip is planar "
                    f"({_numbers((context.n_links,))})")
        if context.spatial and not self.spatial and not self.needs_truth:
            return (f"estimator {self.name!r} gives planar joint angles; this clip's arm "
                    f"moves in 3-D")
        if not (self.spatial or context.spatial) and context.n_links not in self.links:
            return (f"estimator {self.name!r} follows {self.links_text}; "
                    f"this clip has {context.n_links}")
        if self.demonstrators is not None and context.demonstrator not in self.demonstrators:
            return (f"estimator {self.name!r} reads a {' or '.join(self.demonstrators)} "
                    f"demonstrator's arm; this clip shows a {context.demonstrator!r} "
                    f"demonstrator")
        if self.needs_truth and context.truth is None:
            return f"estimator {self.name!r} reads the clip's truth; this clip has none"
        return None


def _numbers(links: tuple[int, ...]) -> str:
    """(1,) -> "one moving link"; (2,) -> "2 moving links"; (1, 2, 3) -> "1 to 3 moving
    links"."""
    if links == (1,):
        return "one moving link"
    if len(links) > 2 and links == tuple(range(links[0], links[-1] + 1)):
        return f"{links[0]} to {links[-1]} moving links"
    return " or ".join(map(str, links)) + " moving links"


ESTIMATORS: dict[str, EstimatorEntry] = {}


def register(entry: EstimatorEntry, replace: bool = False) -> EstimatorEntry:
    """Add ``entry`` under its name (``replace`` allows a name already taken)."""
    if entry.name in ESTIMATORS and not replace:
        raise ValueError(f"an estimator named {entry.name!r} is registered already")
    ESTIMATORS[entry.name] = entry
    return entry


def unregister(name: str) -> None:
    """Remove the estimator ``name`` (tests that register a toy one)."""
    ESTIMATORS.pop(name, None)


def get_estimator(name: str) -> EstimatorEntry:
    """The entry ``name``; ValueError naming the registered ones otherwise."""
    try:
        return ESTIMATORS[name]
    except KeyError:
        raise ValueError(f"unknown estimator {name!r}; expected one of "
                         f"{sorted(ESTIMATORS)}") from None


def build_estimator(name: str, context: EstimatorContext, **params: Any) -> Estimator:
    """The planar estimator ``name`` set up for ``context``. Raises `UnsupportedClipError`
    for a clip it cannot follow (a spatial estimator follows no planar clip) and
    ValueError for a parameter it does not take."""
    estimator: Estimator = _build(name, context, params, spatial=False)
    return estimator


def build_spatial_estimator(name: str, context: EstimatorContext, **params: Any
                            ) -> SpatialEstimator:
    """The spatial estimator ``name`` set up for ``context`` (a spatial one); errors as
    `build_estimator`'s."""
    estimator: SpatialEstimator = _build(name, context, params, spatial=True)
    return estimator


def _build(name: str, context: EstimatorContext, params: dict[str, Any], spatial: bool
           ) -> Any:
    entry = get_estimator(name)
    why = entry.unsupported(context)
    if why is not None:
        raise UnsupportedClipError(why)
    if entry.spatial != spatial:
        wanted = "build_spatial_estimator" if entry.spatial else "build_estimator"
        raise ValueError(f"estimator {name!r} is {'spatial' if entry.spatial else 'planar'}: "
                         f"build it with {wanted}")
    unknown = sorted(set(params) - set(entry.params))
    if unknown:
        takes = ", ".join(entry.params) if entry.params else "no parameters"
        raise ValueError(f"estimator {name!r} does not take {', '.join(unknown)} "
                         f"(it takes {takes})")
    return entry.build(context, **params)


# The built-in estimators --------------------------------------------------------------
# What DON and LinkedDON take: where the clip puts things, a whole config, or any field of
# one (`config.DONConfig`, `config.LinkedDONConfig`), over the modality's preset.
_DON_PARAMS = ("fps", "pivot", "joint_range", "reference_direction", "config",
               *(f.name for f in fields(DONConfig)))
_LINKED_PARAMS = ("pivot", "config", *(f.name for f in fields(LinkedDONConfig)))
_DON_ANY_PARAMS = (*_DON_PARAMS, *(p for p in _LINKED_PARAMS if p not in _DON_PARAMS))


def _don(appearance: bool) -> Callable[..., Estimator]:
    def build(context: EstimatorContext, **params: Any) -> Estimator:
        """DON for one link, `LinkedDON` for several, each with the modality's preset."""
        common = {"fps": context.fps, "reference_direction": context.reference_direction,
                  "robot": context.robot}
        allowed = _DON_PARAMS if context.n_links == 1 else _LINKED_PARAMS
        unknown = sorted(set(params) - set(allowed))
        if unknown:
            raise ValueError(f"DON for {context.n_links} link{'s' if context.n_links > 1 else ''}"
                             f" does not take {', '.join(unknown)}")
        # A config given wins over the preset; don-paper's has no appearance layer.
        given = params.pop("config", None)
        if context.n_links == 1:
            from imimic_gym.estimators.don.one_link import DON

            config = given or don_preset(context.modality)
            if not appearance:
                config = override(config, {"appearance": False})
            return DON(**{"joint_range": tuple(context.joint_ranges[0]), **common,
                          "config": config, **params})
        from imimic_gym.estimators.don.linked import LinkedDON

        linked = given or linked_don_preset(context.modality)
        if not appearance:
            linked = override(linked, {"appearance": False})
        return LinkedDON(context.link_parents, context.joint_ranges,
                         **{**common, "config": linked, **params})

    return build


def _don_frames(params: Mapping[str, Any]) -> int:
    return int(params.get("window", 10)) + 1


def _baseline(kind: str) -> Callable[..., Estimator]:
    def build(context: EstimatorContext, **params: Any) -> Estimator:
        from imimic_gym.estimators import baselines

        cls = baselines.MOG2Estimator if kind == "mog2" else baselines.CamShiftEstimator
        low, high = context.joint_ranges[0]
        return cls(fps=context.fps, reference_direction=context.reference_direction,
                   joint_range=(low, high), **params)

    return build


def _cnn(context: EstimatorContext, **params: Any) -> Estimator:
    from imimic_gym.estimators.cnn.estimator import CNNEstimator

    return CNNEstimator(n_links=context.n_links, fps=context.fps,
                        reference_direction=context.reference_direction, robot=context.robot,
                        **params)


def _pose(context: EstimatorContext, **params: Any) -> Estimator:
    from imimic_gym.estimators.pose.planar import PoseEstimator

    return PoseEstimator(n_links=context.n_links, fps=context.fps,
                         reference_direction=context.reference_direction,
                         robot=context.robot, **params)


def _pose_don(context: EstimatorContext, **params: Any) -> Estimator:
    from imimic_gym.estimators.pose.seeded_don import PoseSeededDON

    return PoseSeededDON(fps=context.fps, reference_direction=context.reference_direction,
                         robot=context.robot, **params)


_POSE3D_PARAMS = ("arm", "min_confidence")


def _pose3d(source: str) -> Callable[..., SpatialEstimator]:
    def build(context: EstimatorContext, **params: Any) -> SpatialEstimator:
        from imimic_gym.estimators.pose.spatial import Pose3DEstimator

        return Pose3DEstimator(fps=context.fps, intrinsics=context.intrinsics,
                               source=params.pop("source", source), **params)

    return build


class TruthReader:
    """The oracle "estimator": the true angles, omega and alpha of the frame the env
    shows (from `EstimatorContext.truth`), trust 1, torque 0. Evaluation only: never
    train a policy on it."""

    def __init__(self, truth: Callable[[], Estimate]) -> None:
        self.truth = truth

    def reset(self) -> None:
        """Stateless: the env knows which frame it shows."""

    def update(self, frame: Any) -> Estimate:
        return self.truth()


def _oracle(context: EstimatorContext, **params: Any) -> Estimator:
    assert context.truth is not None  # checked by EstimatorEntry.unsupported
    return TruthReader(context.truth)


for _entry in (
    EstimatorEntry("don", "DON (frame differences, no labels; with its appearance layer)",
                   _don(appearance=True), links=(1, 2, 3), params=_DON_ANY_PARAMS,
                   frames_needed=_don_frames),
    EstimatorEntry("don-paper", "DON with the paper's layers alone (no appearance layer)",
                   _don(appearance=False), links=(1, 2, 3),
                   params=tuple(p for p in _DON_ANY_PARAMS if p != "appearance"),
                   frames_needed=_don_frames),
    EstimatorEntry("cnn", "CNN + refiner (shipped checkpoint)", _cnn, links=(1, 2),
                   demonstrators=("human",), params=("checkpoint", "refine", "threads"),
                   photos=True),
    EstimatorEntry("mog2", "MOG2 background subtraction (baseline)", _baseline("mog2"),
                   params=("working_height", "gaussian", "min_area")),
    EstimatorEntry("camshift", "CamShift colour tracking (baseline)", _baseline("camshift"),
                   params=("working_height", "gaussian", "min_area")),
    EstimatorEntry("pose", "pretrained human pose model (MediaPipe BlazePose) on every frame",
                   _pose, links=(1, 2), demonstrators=("human",),
                   params=("arm", "min_confidence"), real_people=True, photos=True),
    EstimatorEntry("pose-don", "DON on a crop about the elbow, seeded and re-seeded by the "
                   "pose model every few frames", _pose_don, demonstrators=("human",),
                   params=("arm", "min_confidence", "pose_every", "window"), real_people=True),
    EstimatorEntry("oracle", "oracle (the true angles)", _oracle, links=(1, 2, 3),
                   needs_truth=True),
    EstimatorEntry("pose3d", "the pose model's 2-D keypoints lifted to 3-D by bone lengths "
                   "(source='depth': back-projected through a depth image)", _pose3d("lift"),
                   demonstrators=("human",), params=(*_POSE3D_PARAMS, "source"),
                   real_people=True, spatial=True),
    EstimatorEntry("pose3d-depth", "the pose model's keypoints back-projected through the "
                   "depth image (an RGB-D camera)", _pose3d("depth"), demonstrators=("human",),
                   params=_POSE3D_PARAMS, real_people=True, spatial=True),
    EstimatorEntry("pose-world", "the pose model's own 3-D world landmarks (the baseline)",
                   _pose3d("world"), demonstrators=("human",), params=_POSE3D_PARAMS,
                   real_people=True, spatial=True),
):
    register(_entry)
