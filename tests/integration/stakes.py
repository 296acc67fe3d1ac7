"""The upright stakes of a scene, for the tests' closed-form and brute-force log clearances."""

from __future__ import annotations

from motionlib.model.scene import Scene


def stakes(scene: Scene) -> list[tuple[float, float, float, float, float]]:
    """The scene's stakes (upright cylinders named ``stake*``): (x, y, z_bottom, z_top, radius)."""
    out = []
    for o in scene.obstacles:
        if o.name.startswith("stake"):
            assert o.shape == "cylinder" and not any(o.rpy) and o.radius is not None and o.length is not None
            x, y, z = o.xyz
            out.append((x, y, z - o.length / 2, z + o.length / 2, o.radius))
    return out
