"""Python clients of the hrrtc haptic loop and planner: typed readers of the loop's
``HapticState`` (following a restarted loop), of the planner's ``Guidance``, ``Path`` and
``Roadmap``, and a ``Guidance`` publisher, on the official ``iceoryx2`` bindings.

>>> import hrrtc
>>> node = hrrtc.create_node()
>>> state = hrrtc.StateReader(node, "default").read()
>>> state.user_pose.position_m[:]   # scene frame, m
"""

from .client import (
    DEFAULT_NAMESPACE,
    GuidancePublisher,
    GuidanceSubscriber,
    PathSubscriber,
    RoadmapSubscriber,
    StateReader,
    create_node,
    monotonic_ns,
    service_name,
    state_generations,
)
from .wire import (
    CODES,
    CONSTANTS,
    LAYOUT,
    TYPES,
    ContactCode,
    DriverCommand,
    DriverState,
    DriverStatus,
    FaultCode,
    Guidance,
    GuidanceFreshness,
    GuidanceMode,
    HapticState,
    Header,
    OutputCode,
    Path,
    Pose,
    Roadmap,
    RoadmapNode,
    RoadmapTree,
    TreeKind,
    Twist,
    Wrench,
)

__all__ = [name for name in dir() if not name.startswith("_")]
