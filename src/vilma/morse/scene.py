"""What a MORSE client learns of the scene: the robot's structure (``simulation details``), where it and its
components are (``get_scene_objects``) and how a component is configured (``get_configurations``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from vilma.core.geometry import quaternion_from_euler
from vilma.morse.components import (
    ROBOT_SERVICES,
    ROBOT_TYPE,
    SERVICE_MANAGER,
    STREAM_MANAGER,
    ComponentSpec,
    rotate,
)

ENVIRONMENT = "vilma/flat"
"""The ``environment`` of ``simulation details``: vilma's flat ground."""
IDENTITY = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
"""The rotation from every component's frame to the robot's (their axes are the body's), as rows."""

Mounts = Mapping[str, tuple[float, float, float]]


def details(robot: str, specs: Mapping[str, ComponentSpec], stream_ports: Mapping[str, int]) -> dict[str, Any]:
    """The scene structure pymorse builds its proxies from (``reference/morse-protocol.md`` section 4), for
    ``robot``'s components ``specs`` (by full name) with their datastream ports."""
    comps: dict[str, Any] = {}
    for fqn, spec in specs.items():
        c: dict[str, Any] = {"type": spec.type}
        if spec.services:
            c["services"] = list(spec.services)
            c["service_interfaces"] = [SERVICE_MANAGER]
        if fqn in stream_ports:
            c["stream_interfaces"] = [[STREAM_MANAGER, spec.direction]]
        comps[fqn] = c
    desc = {"name": robot, "type": ROBOT_TYPE, "components": comps,
            "services": list(ROBOT_SERVICES), "services_interfaces": [SERVICE_MANAGER]}
    return {"robots": [desc], "environment": ENVIRONMENT}


def scene_objects(robot: str, specs: Mapping[str, ComponentSpec], mounts: Mounts,
                  pose: Mapping[str, float]) -> dict[str, Any]:
    """``{robot: [children, [x, y, z], [qx, qy, qz, qw]]}``: the robot at ``pose`` (its pose sensor's MORSE
    dict), its components at their mounts (``{fqn: [{}, position, quaternion]}``); vilma's flat ground has no
    objects (the 3D plant's obstacles and laser are not listed)."""
    at = [pose["x"], pose["y"], pose["z"]]
    q = tuple(float(v) for v in quaternion_from_euler(pose["roll"], pose["pitch"], pose["yaw"]))
    children = {}
    for fqn, spec in specs.items():
        if spec.name in mounts:
            offset = rotate(q, mounts[spec.name])
            children[fqn] = [{}, [a + d for a, d in zip(at, offset, strict=True)], list(q)]
    return {robot: [children, at, list(q)]}


def configurations(spec: ComponentSpec, mounts: Mounts) -> dict[str, Any]:
    """MORSE's ``get_configurations``: the properties' values and where the component sits on the robot."""
    return {"configurations": {**{name: value[0] for name, value in spec.properties},
                               "object_to_robot": {"rotation": IDENTITY, "translation": list(mounts[spec.name])}}}
