"""Robot descriptions (URDF, MJCF, SDFormat) read into one plain, host-side form: `load` and the
`ModelDescription` it returns (warpdyn.description.model), the lumped tree (`tree`) and the collidable points
of its shapes (`collidable`). Host code only (NumPy, float64, SI units): nothing here touches a device.

Readers: URDF with yourdfpy (`urdf`), MJCF compiled by MuJoCo (`mjcf`), SDFormat 1.4 to 1.11 with
xml.etree and no Gazebo library (`sdf`; docs/formats_sdf.md says what it reads and refuses).
"""

from __future__ import annotations

import os
import pathlib
import re
import xml.etree.ElementTree as ET

import numpy as np

from .mjcf import load_mjcf
from .model import (
    ActuatorDescription,
    CollisionShape,
    FrameDescription,
    NotModelledWarning,
    JOINT_COORDINATES,
    JOINT_DOFS,
    JointDescription,
    Keyframe,
    LinkDescription,
    ModelDescription,
    axis_angle_to_matrix,
    identity_position,
    joint_motion,
    quaternion_wxyz_to_matrix,
    warn_not_modelled,
)
from .physical import UnphysicalInertiaWarning, check_description
from .sdf import load_sdf
from .urdf import load_urdf

__all__ = [
    "LinkDescription",
    "JointDescription",
    "CollisionShape",
    "FrameDescription",
    "ActuatorDescription",
    "ModelDescription",
    "Keyframe",
    "JOINT_COORDINATES",
    "JOINT_DOFS",
    "identity_position",
    "NotModelledWarning",
    "UnphysicalInertiaWarning",
    "load",
    "joint_motion",
    "axis_angle_to_matrix",
    "quaternion_wxyz_to_matrix",
]


_XML_DECLARATION = re.compile(r"^\s*<\?xml[^>]*\?>")


def _looks_like_xml(text: str) -> bool:
    return text.lstrip("\ufeff \t\r\n").startswith("<")


def _read_document(model_description) -> tuple[bytes, str | None]:
    """(the document's bytes, its path or None) of a path, an XML string or XML bytes.

    Files and bytes are handed to the XML parsers as bytes, which honour a byte-order mark and the encoding
    an XML declaration names. A string is already decoded: its BOM and XML declaration (whose encoding no
    longer applies) are dropped and the text is encoded as UTF-8.
    """
    if isinstance(model_description, (bytes, bytearray, memoryview)):
        return bytes(model_description), None
    if isinstance(model_description, os.PathLike) or (
        isinstance(model_description, str) and not _looks_like_xml(model_description)
    ):
        path = pathlib.Path(model_description).expanduser()
        if not path.is_file():
            shown = str(model_description)
            a_path = isinstance(model_description, os.PathLike) or ("\n" not in shown and len(shown) <= 4096)
            shown = repr(shown if a_path or len(shown) <= 80 else shown[:80] + "...")  # a path in full, text cut
            raise FileNotFoundError(f"robot description {shown} does not exist or is not a file (nor an XML document)")
        return path.read_bytes(), str(path)
    if isinstance(model_description, str):
        text = _XML_DECLARATION.sub("", model_description.lstrip("\ufeff"), count=1)
        return text.encode("utf-8"), None
    raise TypeError(
        "model_description must be a path, an XML string or XML bytes, got an object of type "
        f"{type(model_description).__name__}"
    )


def load(
    model_description, *, is_urdf: bool | None = None, fixed_base: bool | None = None, base_pose=None
) -> ModelDescription:
    """Read a URDF, MJCF or SDFormat description (a path, an XML string or XML bytes) into a `ModelDescription`.

    The format is the root element's: `<robot>` URDF, `<mujoco>` MJCF, `<sdf>` SDFormat (1.4 to 1.11; its
    `<include>`s resolve against the file's directory, or the working directory for an XML string, and the
    resource paths, see warpdyn.description.sdf). is_urdf (JaxSim's keyword): True reads the document as a
    URDF whatever its root; False as MJCF or SDFormat by its root; None detects it.

    fixed_base: None keeps what the description says (a root welded to a `world` link, an MJCF body
    without a free joint, a static SDF model is a fixed base); True welds the base to the world (an MJCF
    free joint becomes a weld) at `base_pose`; False frees a base the description welds to the world.
    base_pose (4, 4): the homogeneous transform W_H_B of the welded base (default: the description's weld,
    else where it places its floating base (`initial_world_H_base`, SDF), else the identity). A freed SDF
    base starts where the description welded it (`initial_world_H_base`); a freed URDF or MJCF base at the
    origin.

    Elements of the description that warpdyn does not model (`ModelDescription.not_modelled`: MJCF
    constraints, tendons, unsupported actuators..., URDF mimic joints, SDF sensors, plugins, surfaces...)
    are listed in one `NotModelledWarning`, pointing at the first caller outside warpdyn.
    """
    document, path = _read_document(model_description)
    where = f"'{path}'" if path else "the given XML document"
    try:
        root = ET.fromstring(document)
    except ET.ParseError as error:
        raise ValueError(f"{where} is not well-formed XML: {error}") from None
    if is_urdf is None:
        if root.tag not in ("robot", "mujoco", "sdf"):
            raise ValueError(
                f"{where} has root element <{root.tag}>: expected <robot> (URDF), <mujoco> (MJCF) or <sdf> (SDFormat)"
            )
        is_urdf = root.tag == "robot"
    is_sdf = not is_urdf and root.tag == "sdf"
    if not is_urdf and not is_sdf and path is not None:
        try:
            document.decode("utf-8")
        except UnicodeDecodeError as error:  # MuJoCo reads a file's bytes as UTF-8, whatever it declares
            raise ValueError(
                f"{where} is not UTF-8 (byte {error.start}): MuJoCo reads MJCF files as UTF-8; save it as UTF-8, or pass its "
                "text (a str) instead of its path"
            ) from None
    if is_urdf:
        description = load_urdf(document, where)
    elif is_sdf:
        description = load_sdf(root, path, where)
    else:
        description = load_mjcf(root, path, where)
    description.path = path
    check_description(description, where)
    description = _with_base(description, fixed_base, base_pose, where)
    warn_not_modelled(where, description.not_modelled)
    return description


def _with_base(description: ModelDescription, fixed_base: bool | None, base_pose, where: str) -> ModelDescription:
    """The description with its base welded or freed as `load` documents."""
    if base_pose is not None:
        H = np.asarray(base_pose, dtype=np.float64)
        if H.shape != (4, 4) or not np.all(np.isfinite(H)):
            raise ValueError(f"base_pose must be a finite (4, 4) homogeneous transform, got shape {H.shape}")
        R = H[:3, :3]
        if np.abs(R @ R.T - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0.0 or np.abs(H[3] - [0, 0, 0, 1]).max() > 1e-12:
            raise ValueError("base_pose must be a homogeneous transform: a rotation block (det +1) and last row (0, 0, 0, 1)")
        if fixed_base is False or (fixed_base is None and not description.fixed_base):
            raise ValueError("base_pose places a welded base: pass fixed_base=True (a floating base's pose is in the data)")
    if fixed_base is None or bool(fixed_base) == description.fixed_base:
        if base_pose is not None:
            description.world_H_base = H
        return description
    if fixed_base:
        placed = description.initial_world_H_base
        description.fixed_base = True
        description.world_H_base = H if base_pose is not None else (np.eye(4) if placed is None else placed)
        description.initial_world_H_base = None
        return description
    if description.base == "world":
        raise ValueError(
            f"{where}: fixed_base=False, but the world has several bodies welded or jointed to it: there is no one "
            "base to free"
        )
    description.fixed_base = False
    if description.source == "sdf":  # SDF says where the model is: the freed base starts there
        description.initial_world_H_base = description.world_H_base
    description.world_H_base = np.eye(4)
    return description


