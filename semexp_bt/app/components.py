"""The one place that builds a mission's components by name: robot backend, perception source, relevance
scorer, planner and gait.

Each kind is a table from a name to a builder; a new backend, model or planner is one new module plus one
row here. Builders take a :class:`ComponentRequest` (what the caller knows: the scene when it is a
simulated one, the seed, the strategy, the fidelity) and import their implementation lazily, so that
naming a component never loads the libraries of the others (``semexp-bt run --backend ros2`` needs no
MuJoCo renderer; a lexical run needs no torch).

Example:
    >>> sorted(RELEVANCE_SCORERS)
    ['embedding', 'hybrid', 'lexical', 'llm']
    >>> build_relevance("lexical").score(instruction="find the red chair", label="chair") > 0.5
    True
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar, cast

from semexp_bt.app.strategies import Strategy
from semexp_bt.core.relevance import CachedRelevance
from semexp_bt.core.types import InvalidInputError, Pose2D

if TYPE_CHECKING:
    from robots.gait_policy import GaitController
    from robots.interface import Fidelity, Robot
    from semexp_bt.core.scene import SceneSpec
    from semexp_bt.nav.controller import PathController
    from semexp_bt.perception.adapters.stack import ModelStack
    from semexp_bt.perception.interface import PerceptionSource


class UnknownComponentError(InvalidInputError):
    """A component name that its table does not hold (the message lists the known ones)."""


@dataclass(frozen=True)
class ComponentRequest:
    """What a builder may use.

    Attributes:
        seed: the episode's seed (noise of simulated sensors and models).
        strategy: the strategy (which perception sources run, the emulated detector's profile).
        fidelity: ``kinematic`` or ``dynamic``.
        scene: the simulated scene, for simulated components (None on a real robot).
        start_pose: where a simulated robot starts.
        models: the real models of a models profile, shared by the ``models`` perception source and the
            ``llm`` relevance scorer (None when the run names no profile).
        robot_options: backend-specific options (``ros2``: ``profile``, the robot profile's path or None;
            ``simulation``, whether to read the simulation bridge's ``/sim/...`` topics).
    """

    seed: int
    strategy: Strategy
    fidelity: Fidelity = "kinematic"
    scene: SceneSpec | None = None
    start_pose: Pose2D | None = None
    models: ModelStack | None = None

    robot_options: Mapping[str, Any] = field(default_factory=dict)

    def require_models(self, component: str) -> ModelStack:
        """The models profile's stack, or a clear error naming the component that needs one."""
        if self.models is None:
            raise InvalidInputError(
                f"{component} needs a models profile (give --models, or --vlm-url/--llm-url)"
            )
        return self.models

    def require_scene(self, component: str) -> SceneSpec:
        """The simulated scene, or a clear error naming the component that needs one."""
        if self.scene is None or self.start_pose is None:
            raise InvalidInputError(f"{component} needs a simulated scene (give --scene)")
        return self.scene


def _mujoco_robot(request: ComponentRequest) -> Robot:
    from robots.mujoco_backend import MujocoRobot

    scene = request.require_scene("the mujoco backend")
    assert request.start_pose is not None  # checked by require_scene
    return MujocoRobot(
        scene=scene, fidelity=request.fidelity, start_pose=request.start_pose, seed=request.seed
    )


def _ros2_robot(request: ComponentRequest) -> Robot:
    from robots.ros2_backend import Ros2Robot
    from robots.ros2_profile import load_ros2_profile

    options = request.robot_options
    return Ros2Robot(
        load_ros2_profile(options.get("profile")), simulation=bool(options.get("simulation", False))
    )


def _emulated_perception(request: ComponentRequest) -> PerceptionSource:
    from sims.perception_emulator import PerceptionEmulator

    strategy = request.strategy
    return PerceptionEmulator(
        request.require_scene("the perception emulator"),
        seed=request.seed,
        detector_profile=cast(Any, strategy.detector_profile),
        enable_vlm=strategy.enable_vlm,
        enable_detector=strategy.enable_detector,
    )


def _model_perception(request: ComponentRequest) -> PerceptionSource:
    strategy = request.strategy
    return request.require_models("the models perception source").perception(
        enable_vlm=strategy.enable_vlm, enable_detector=strategy.enable_detector
    )


def _embedding_relevance(request: ComponentRequest | None) -> CachedRelevance:
    from semexp_bt.perception.embedding_relevance import shared_embedding_relevance

    return CachedRelevance(shared_embedding_relevance())


def _hybrid_relevance(request: ComponentRequest | None) -> CachedRelevance:
    from semexp_bt.core.relevance import HybridRelevance
    from semexp_bt.perception.embedding_relevance import shared_embedding_relevance

    return CachedRelevance(HybridRelevance(shared_embedding_relevance()))


def _lexical_relevance(request: ComponentRequest | None) -> CachedRelevance:
    from semexp_bt.core.relevance import LexicalRelevance

    return CachedRelevance(LexicalRelevance())


def _llm_relevance(request: ComponentRequest | None) -> CachedRelevance:
    if request is None:
        raise InvalidInputError(
            "the llm relevance scorer needs a models profile (give --models or --llm-url)"
        )
    return CachedRelevance(request.require_models("the llm relevance scorer").relevance())


def _dwb_controller() -> PathController:
    from semexp_bt.nav.dwb import DwbController

    return DwbController()


def _pure_pursuit_controller() -> PathController:
    from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit

    return RegulatedPurePursuit()


#: Robot backends: name -> builder.
ROBOT_BACKENDS: dict[str, Callable[[ComponentRequest], Robot]] = {
    "mujoco": _mujoco_robot,
    "ros2": _ros2_robot,
}
#: Perception sources: name -> builder.
PERCEPTION_SOURCES: dict[str, Callable[[ComponentRequest], PerceptionSource]] = {
    "emulator": _emulated_perception,
    "models": _model_perception,
}
#: Relevance scorers S in [0, 1]: name -> builder of a cached scorer (a fresh cache per mission).
RELEVANCE_SCORERS: dict[str, Callable[[ComponentRequest | None], CachedRelevance]] = {
    "embedding": _embedding_relevance,
    "hybrid": _hybrid_relevance,
    "lexical": _lexical_relevance,
    "llm": _llm_relevance,
}
#: Path-following controllers on the costmap (docs/planner.md compares them): name -> builder.
PLANNERS: dict[str, Callable[[], PathController]] = {"dwb": _dwb_controller, "rpp": _pure_pursuit_controller}
#: The controller a mission uses unless told otherwise.
DEFAULT_PLANNER = "rpp"

_T = TypeVar("_T")


def _lookup(table: Mapping[str, _T], kind: str, name: str) -> _T:
    try:
        return table[name]
    except KeyError:
        raise UnknownComponentError(f"unknown {kind} {name!r}; known: {', '.join(sorted(table))}") from None


def build_robot(name: str, request: ComponentRequest) -> Robot:
    """The robot backend called ``name``."""
    return _lookup(ROBOT_BACKENDS, "robot backend", name)(request)


def build_perception(name: str, request: ComponentRequest) -> PerceptionSource:
    """The perception source called ``name``."""
    return _lookup(PERCEPTION_SOURCES, "perception source", name)(request)


def build_relevance(name: str, request: ComponentRequest | None = None) -> CachedRelevance:
    """The relevance scorer called ``name``, behind a fresh per-mission cache (``llm`` needs a request
    with a models profile)."""
    return _lookup(RELEVANCE_SCORERS, "relevance scorer", name)(request)


def build_planner(name: str) -> PathController:
    """The path-following controller called ``name``."""
    return _lookup(PLANNERS, "planner", name)()


def build_gait(fidelity: Fidelity) -> GaitController | None:
    """What realises twists: nothing in kinematic fidelity (the base follows the twist), the shipped RL
    policy in dynamic fidelity (one controller per mission: it keeps its own state)."""
    if fidelity != "dynamic":
        return None
    from robots.gait_policy import make_gait_controller

    return cast("GaitController", make_gait_controller())
