"""Regenerate the recorded-work data set of this folder (see README.md): ``python data/recorded-work/generate.py``."""

from __future__ import annotations

from pathlib import Path

from motionlib.analysis.recording import write_recording
from motionlib.experiment.recorded_work import simulate_work
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene

HERE = Path(__file__).resolve().parent
SCENE = HERE.parents[1] / "obstacles" / "forwarder-site.yaml"
#: (operator, mode, seed): an expert and a novice of the panel, in manual joint (M1) and Cartesian (M4) operation.
RUNS = (("O1", "M1", 1), ("O1", "M4", 2), ("O4", "M1", 3), ("O4", "M4", 4))
CYCLES = 3


def main() -> None:
    crane = Crane.load("forwarder")
    scene = Scene.load(SCENE, crane=crane)
    for operator, mode, seed in RUNS:
        rec = simulate_work(crane, scene, operator, mode, cycles=CYCLES, seed=seed)
        out = HERE / f"{operator.lower()}-{mode.lower()}.csv"
        write_recording(out, rec, scene_path="../../obstacles/forwarder-site.yaml")
        print(f"{out.name}: {rec.duration_s:.1f} s, {rec.t.size} samples, {len(rec.events)} grapple events")


if __name__ == "__main__":
    main()
