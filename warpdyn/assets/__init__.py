"""Robot descriptions shipped with warpdyn.

- `ergocub_urdf()`: the ergoCub humanoid, serial SN001 (the robot of JaxSim's notebook "JaxSim as a
  multibody dynamics library" that warpdyn's tour and tests use), from the ergocub-software repository of
  iCub Tech (https://github.com/icub-tech-iit/ergocub-software), BSD-3-Clause: its licence text is
  `LICENSE.ergoCub` beside the file. Meshes are not included: its collision boxes and spheres give the
  collidable points; its mesh URIs (`package://ergoCub/...`) stay unresolved.
"""

from __future__ import annotations

import pathlib

__all__ = ["ergocub_urdf", "ERGOCUB_LEG_JOINTS"]

_HERE = pathlib.Path(__file__).resolve().parent

ERGOCUB_LEG_JOINTS = (
    "l_hip_pitch",
    "l_hip_roll",
    "l_hip_yaw",
    "l_knee",
    "l_ankle_pitch",
    "l_ankle_roll",
    "r_hip_pitch",
    "r_hip_roll",
    "r_hip_yaw",
    "r_knee",
    "r_ankle_pitch",
    "r_ankle_roll",
)
"""The twelve leg joints of the ergoCub, the ones JaxSim's notebook keeps."""


def ergocub_urdf() -> pathlib.Path:
    """The path of the shipped ergoCubSN001 URDF (a file inside the installed package)."""
    return _HERE / "ergoCubSN001.urdf"
