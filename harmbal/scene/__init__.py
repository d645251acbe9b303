"""The scene stage: what the user describes, read from TOML, validated and
converted to SI once (units, schema, the readers of each table, balancer
elements, design/verify requests, the powertrain and its mounts, firing
order, the scene writer)."""

from .mounts import Mount, MountDesignRequest, MountTable, MountVariable, Powertrain, RigidPart
from .reader import load_scene, scene_from_text
from .schema import EFFECTS, MAX_SPEEDS, Cylinder, Model, Scene, SceneError

__all__ = ["EFFECTS", "MAX_SPEEDS", "Cylinder", "Model", "Mount", "MountDesignRequest", "MountTable", "MountVariable",
           "Powertrain", "RigidPart", "Scene", "SceneError", "load_scene", "scene_from_text"]
