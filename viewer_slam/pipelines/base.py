"""The pipeline interface and the registry that builds pipelines by name.

The registry holds the built-in pipelines and every installed plugin: a distribution that
declares an entry point in the ``viewslam.pipelines`` group, named after the pipeline and
pointing at a :class:`Pipeline` subclass (see docs/plugins.md). Plugins are imported only
when one is used or listed, and a plugin that cannot be imported, or is not a pipeline, is
an :class:`InputError` naming it when it is selected, never an obstacle to the others.
"""

import importlib
import re
from abc import ABC, abstractmethod
from importlib.metadata import EntryPoint, entry_points
from typing import TYPE_CHECKING, Any, ClassVar

from ..dataset.frame import Frame
from ..errors import InputError
from ..geometry.camera import Camera
from .events import Event

if TYPE_CHECKING:
    from .params import PipelineParams

ENTRY_POINT_GROUP = "viewslam.pipelines"
RUN_NAME = re.compile(r"[A-Za-z0-9_.-]+")
"""The names a run may have (a pipeline, a plugin, an estimate): each names entity paths and a file."""
# Pipelines are imported on first use so that `viewslam evaluate` never pays for them.
PIPELINE_MODULES = {"rgbdslam": "viewer_slam.pipelines.rgbdslam", "rtabmap": "viewer_slam.pipelines.rtabmap"}


class Pipeline(ABC):
    """Fed frames in order; returns the events each frame produced.

    ``seed`` drives every random choice (RANSAC, candidate sampling), so the same frames,
    parameters and seed give the same events.
    """

    name: ClassVar[str]
    source: ClassVar[str] = "pipeline"  # where a run's poses come from; an imported estimate says "estimate"
    Params: ClassVar[type["PipelineParams"]]

    def __init__(self, camera: Camera, params: Any = None, seed: int = 0):
        self.camera = camera
        self.params = params if params is not None else self.Params()
        self.seed = seed

    def prefetch(self, frame: Frame) -> None:  # noqa: B027  (a hook: subclasses may override it, need not)
        """Shown each frame, in order, before :meth:`process` gets it (one frame ahead), so that
        work which does not depend on the map can start early; by default nothing is done."""

    @abstractmethod
    def process(self, frame: Frame) -> list[Event]:
        """Track one frame; the list always holds exactly one FrameTracked."""

    @abstractmethod
    def finish(self) -> list[Event]:
        """Final optimisation; the list ends with a TrajectoryFinal."""


def plugin_entry_points() -> dict[str, EntryPoint]:
    """Installed plugins by pipeline name (not imported yet), in discovery order."""
    return {point.name: point for point in entry_points(group=ENTRY_POINT_GROUP)}


def pipeline_names() -> list[str]:
    """Every pipeline that can be selected: the built-in ones, then the plugins."""
    return [*PIPELINE_MODULES, *(name for name in plugin_entry_points() if name not in PIPELINE_MODULES)]


def pipeline_class(name: str) -> type[Pipeline]:
    if name in PIPELINE_MODULES:
        return importlib.import_module(PIPELINE_MODULES[name]).PIPELINE
    plugin = plugin_entry_points().get(name)
    if plugin is None:
        raise InputError(f"unknown pipeline {name!r}; valid: {', '.join(pipeline_names())}")
    return load_plugin(plugin)


def load_plugin(plugin: EntryPoint) -> type[Pipeline]:
    """The class a plugin's entry point names, checked to be a pipeline."""
    where = f"pipeline plugin {plugin.name!r} ({plugin.value})"
    if plugin.name in PIPELINE_MODULES:
        raise InputError(f"{where}: the name is taken by a built-in pipeline")
    if not RUN_NAME.fullmatch(plugin.name):
        raise InputError(
            f"{where}: a pipeline's name holds letters, digits, '_', '-' and '.' only (it names entities and files)"
        )
    try:
        loaded = plugin.load()
    except (Exception, SystemExit) as error:  # whatever the plugin's import raises, it is the plugin's fault
        problem = (
            f"called sys.exit({error.code!r})"
            if isinstance(error, SystemExit)
            else f"{type(error).__name__}: {' '.join(str(error).split())}"
        )
        raise InputError(f"{where}: cannot be imported: {problem}") from None
    unusable = interface_problem(loaded)
    if unusable is not None:
        raise InputError(f"{where}: {unusable}")
    return loaded


def interface_problem(candidate: Any) -> str | None:
    """What keeps ``candidate`` from being a usable pipeline class, or None."""
    if not (isinstance(candidate, type) and issubclass(candidate, Pipeline)):
        return f"{candidate!r} is not a subclass of viewer_slam.pipelines.base.Pipeline"
    if candidate.__abstractmethods__:
        return f"{candidate.__name__} does not implement {', '.join(sorted(candidate.__abstractmethods__))}"
    from .params import PipelineParams

    params = getattr(candidate, "Params", None)
    if not (isinstance(params, type) and issubclass(params, PipelineParams)):
        return (
            f"{candidate.__name__}.Params is not a subclass of viewer_slam.pipelines.params.PipelineParams "
            f"(parameters are a pydantic model, one field per parameter: docs/plugins.md)"
        )
    return declaration_problem(params, f"{candidate.__name__}.Params")


def declaration_problem(params: type["PipelineParams"], where: str) -> str | None:
    """What keeps a parameter model from giving a run its defaults: a field with no default (a
    run may leave any parameter unset), or a default its own declaration refuses; None if none."""
    from pydantic import ValidationError

    from .params import key_of, problem_of

    for name, field in params.model_fields.items():
        if field.is_required():
            return f"{where}: parameter {key_of(name, field)!r} has no default (every parameter needs one)"
    try:
        params.model_validate(params().model_dump(by_alias=True))  # defaults are not validated when declared
    except ValidationError as error:
        return f"{where}: the default of parameter {problem_of(error, params)}"
    except Exception as error:  # a validator of the plugin's own that fails: its fault, in one line
        return f"{where}: its defaults cannot be built: {type(error).__name__}: {' '.join(str(error).split())}"
    return None


def make_pipeline(name: str, camera: Camera, params: Any = None, seed: int = 0) -> Pipeline:
    return pipeline_class(name)(camera, params, seed)
