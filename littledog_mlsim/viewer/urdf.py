"""The package's URDF as drawable shapes, and where they are for given joint angles (plain NumPy).

Why not a URDF library: ``yourdfpy`` (and ``urdfpy``) reject ``<capsule>``, the pybullet
extension our URDF uses for the legs. The URDF is small and regular (revolute and fixed joints,
box/capsule/sphere/cylinder visuals), so it is read here with ``xml.etree``: joints (parent,
child, origin xyz/rpy, axis, type) and each link's visuals (geometry, origin, material colour).

Forward kinematics (:meth:`RobotModel.link_poses`, :meth:`RobotModel.visual_poses`) is
vectorised over frames: for a base pose
(position, quaternion xyzw) and joint angles q in ``layout.JOINT_NAMES`` order, the world
transform of every link is T_parent @ T_origin @ Rot(axis, q); a visual sits at
T_link @ T_visual_origin. ``test/viewer/test_viewer.py`` checks the foot spheres against the
analytic legs of ``gait.ik.forward_kinematics`` (an independent implementation).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..layout import JOINT_NAMES, N_JOINTS
from ..rotations import quat_to_matrix, rpy_to_matrix

__all__ = ["Visual", "Joint", "RobotModel", "load_robot", "matrix_to_wxyz"]

GEOMETRIES = ("box", "capsule", "sphere", "cylinder")


@dataclass(frozen=True)
class Visual:
    """One visual shape of a link: ``kind`` in GEOMETRIES, ``size`` (box: x, y, z; capsule and
    cylinder: radius, length; sphere: radius), its origin in the link frame, RGBA colour."""

    link: str
    kind: str
    size: tuple[float, ...]
    xyz: np.ndarray
    rotation: np.ndarray
    rgba: tuple[float, float, float, float]

    @property
    def key(self) -> tuple:
        """Shapes with the same key share one mesh (drawn as instances of it)."""
        return (self.kind, self.size)


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str            # revolute | continuous | prismatic | fixed
    parent: str
    child: str
    xyz: np.ndarray
    rotation: np.ndarray
    axis: np.ndarray


@dataclass
class RobotModel:
    """Links, joints (in an order where every parent comes before its child) and visuals."""

    root: str
    joints: list[Joint]
    visuals: list[Visual]
    joint_index: dict[str, int] = field(default_factory=dict)   # joint name -> index into q

    def link_poses(self, position: np.ndarray, quat_xyzw: np.ndarray,
                   q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """World rotation (..., 3, 3) and position (..., 3) of every link.

        ``position`` (..., 3), ``quat_xyzw`` (..., 4), ``q`` (..., 12) in JOINT_NAMES order."""
        position = np.asarray(position, dtype=np.float64)
        q = np.asarray(q, dtype=np.float64)
        if q.shape[-1] != N_JOINTS:
            raise ValueError(f"expected joint angles (..., {N_JOINTS}), got {q.shape}")
        R_base = quat_to_matrix(np.asarray(quat_xyzw, dtype=np.float64))
        links: dict[str, tuple[np.ndarray, np.ndarray]] = {self.root: (R_base, position)}
        for j in self.joints:
            R_p, p_p = links[j.parent]
            R = R_p @ j.rotation
            p = p_p + np.einsum("...ij,j->...i", R_p, j.xyz)
            if j.kind in ("revolute", "continuous") and j.name in self.joint_index:
                R = R @ _axis_angle(j.axis, q[..., self.joint_index[j.name]])
            elif j.kind == "prismatic" and j.name in self.joint_index:
                p = p + np.einsum("...ij,j->...i", R, j.axis) * q[..., self.joint_index[j.name],
                                                                    None]
            links[j.child] = (R, p)
        return links

    def visual_poses(self, position: np.ndarray, quat_xyzw: np.ndarray,
                     q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World positions (..., V, 3) and rotation matrices (..., V, 3, 3) of the visuals."""
        links = self.link_poses(position, quat_xyzw, q)
        pos, rot = [], []
        for v in self.visuals:
            R_l, p_l = links[v.link]
            rot.append(R_l @ v.rotation)
            pos.append(p_l + np.einsum("...ij,j->...i", R_l, v.xyz))
        return np.stack(pos, axis=-2), np.stack(rot, axis=-3)

    def link_names(self) -> list[str]:
        return [self.root] + [j.child for j in self.joints]


def _axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) about the unit ``axis`` by ``angle`` (...) (Rodrigues)."""
    a = np.asarray(angle, dtype=np.float64)[..., None, None]
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(a) * K + (1.0 - np.cos(a)) * (K @ K)


def matrix_to_wxyz(R: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4) w, x, y, z (viser's order) of rotation matrices (..., 3, 3)."""
    R = np.asarray(R, dtype=np.float64)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    w = np.sqrt(np.maximum(0.0, 1.0 + m00 + m11 + m22)) / 2
    x = np.sqrt(np.maximum(0.0, 1.0 + m00 - m11 - m22)) / 2
    y = np.sqrt(np.maximum(0.0, 1.0 - m00 + m11 - m22)) / 2
    z = np.sqrt(np.maximum(0.0, 1.0 - m00 - m11 + m22)) / 2
    x = np.copysign(x, R[..., 2, 1] - R[..., 1, 2])
    y = np.copysign(y, R[..., 0, 2] - R[..., 2, 0])
    z = np.copysign(z, R[..., 1, 0] - R[..., 0, 1])
    out = np.stack([w, x, y, z], axis=-1)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def _floats(text: str | None, n: int, what: str, default: float = 0.0) -> np.ndarray:
    if text is None:
        return np.full(n, default)
    try:
        v = np.array([float(t) for t in text.split()])
    except ValueError:
        raise ValueError(f"{what}: not numbers: {text!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what}: expected {n} finite numbers, got {text!r}")
    return v


def _origin(el: ET.Element | None, what: str) -> tuple[np.ndarray, np.ndarray]:
    if el is None:
        return np.zeros(3), np.eye(3)
    return (_floats(el.get("xyz"), 3, f"{what} origin xyz"),
            rpy_to_matrix(_floats(el.get("rpy"), 3, f"{what} origin rpy")))


def _geometry(geom: ET.Element, what: str) -> tuple[str, tuple[float, ...]] | None:
    for child in geom:
        if child.tag == "box":
            return "box", tuple(float(x) for x in _floats(child.get("size"), 3, f"{what} box size"))
        if child.tag in ("capsule", "cylinder"):
            r = _floats(child.get("radius"), 1, f"{what} radius")[0]
            length = _floats(child.get("length"), 1, f"{what} length")[0]
            return child.tag, (float(r), float(length))
        if child.tag == "sphere":
            return "sphere", (float(_floats(child.get("radius"), 1, f"{what} radius")[0]),)
    return None   # a mesh or an unknown shape: not drawn


def load_robot(path: str | Path | None = None) -> RobotModel:
    """Read a URDF (default: the package's ``robot/littledog.urdf``); ValueError naming the
    file and element on anything malformed."""
    if path is None:
        from ..robot.config import URDF_PATH
        path = URDF_PATH
    path = Path(path)
    try:
        root_el = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as e:
        raise ValueError(f"{path}: cannot read the URDF: {e}") from None
    try:
        return _model(root_el)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None


def _model(robot: ET.Element) -> RobotModel:
    materials: dict[str, tuple[float, ...]] = {}
    for m in robot.findall("material"):
        c = m.find("color")
        if m.get("name") and c is not None:
            materials[m.get("name")] = tuple(_floats(c.get("rgba"), 4, f"material {m.get('name')}"))
    links = [ln.get("name") for ln in robot.findall("link")]
    if not links or any(not n for n in links):
        raise ValueError("no links, or a link without a name")
    visuals: list[Visual] = []
    for ln in robot.findall("link"):
        name = ln.get("name")
        for vis in ln.findall("visual"):
            geom = vis.find("geometry")
            shape = _geometry(geom, f"link {name}") if geom is not None else None
            if shape is None:
                continue
            xyz, rot = _origin(vis.find("origin"), f"link {name} visual")
            rgba: tuple[float, ...] = (0.6, 0.6, 0.6, 1.0)
            mat = vis.find("material")
            if mat is not None:
                c = mat.find("color")
                if c is not None:
                    rgba = tuple(_floats(c.get("rgba"), 4, f"link {name} colour"))
                elif mat.get("name") in materials:
                    rgba = materials[mat.get("name")]
            visuals.append(Visual(name, shape[0], shape[1], xyz, rot, tuple(rgba)))  # type: ignore[arg-type]
    joints: list[Joint] = []
    for j in robot.findall("joint"):
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            raise ValueError(f"joint {j.get('name')}: no parent or child")
        xyz, rot = _origin(j.find("origin"), f"joint {j.get('name')}")
        axis_el = j.find("axis")
        axis = _floats(axis_el.get("xyz") if axis_el is not None else None, 3,
                       f"joint {j.get('name')} axis", 0.0)
        if axis_el is None:
            axis = np.array([1.0, 0.0, 0.0])
        norm = np.linalg.norm(axis)
        if j.get("type") != "fixed" and norm == 0:
            raise ValueError(f"joint {j.get('name')}: zero axis")
        joints.append(Joint(j.get("name") or "", j.get("type") or "fixed", parent.get("link"),
                            child.get("link"), xyz, rot, axis / (norm or 1.0)))
    children = {j.child for j in joints}
    roots = [n for n in links if n not in children]
    if len(roots) != 1:
        raise ValueError(f"expected one root link, found {roots}")
    ordered: list[Joint] = []
    known = {roots[0]}
    pending = list(joints)
    while pending:
        ready = [j for j in pending if j.parent in known]
        if not ready:
            raise ValueError("joints do not form a tree under the root link")
        for j in ready:
            ordered.append(j)
            known.add(j.child)
            pending.remove(j)
    index = {n: i for i, n in enumerate(JOINT_NAMES)}
    missing = [n for n in JOINT_NAMES if n not in {j.name for j in joints}]
    if missing:
        raise ValueError(f"no joint(s) {', '.join(missing[:3])}")
    return RobotModel(roots[0], ordered, visuals, index)
