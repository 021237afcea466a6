"""Serial chains from a URDF (what every ROS arm ships as robot_description).

A chain is the joints on the path from ``base_link`` to ``tip_link``, as MoveIt's
kinematics.yaml names it.  Parsed with the standard library's XML parser (the
PyPI URDF parsers are unmaintained or pull in meshes and scene graphs we do not
need).  Per joint: ``origin`` xyz and rpy (R = Rz(yaw) Ry(pitch) Rx(roll), fixed
axes, as URDF defines it), ``axis`` (default x), type:

- ``fixed``: folds into the next joint's origin (or into the tool transform)
- ``revolute`` / ``prismatic``: ``limit`` lower and upper
- ``continuous``: no limits; given the range [-pi, pi], which the solvers wrap
  across (a revolute value leaving its range moves by 2 pi), so no angle is out of reach
- ``mimic``: q = multiplier * q_other + offset, a coupling (the other joint must
  be on the chain)

A joint with axis a becomes F M(q) F' with F = origin * R_a, M = Rz or Tz and
F' = R_a^T (R_a turns z onto a), the form ``Chain`` takes for ``urdf`` chains
(``joint_origins``); the fast kernels are generated from it as for DH chains.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .chain import PRISMATIC, REVOLUTE, URDF, Chain, Coupling
from .errors import ChainConfigError
from .transforms import xyz_rpy_matrix

PACKAGE_SCHEME = "package://"
_MOVING = {"revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}


def urdf_text(source: str, key: str, chain: str) -> str:
    """The XML of ``source``: the XML itself, a ``package://<pkg>/<path>`` resolved
    through the ament index, or a file path."""
    source = source.strip()
    if source.startswith("<"):
        return source
    if source.startswith(PACKAGE_SCHEME):
        from amr_util.share import share_directory

        package, _, relative = source[len(PACKAGE_SCHEME) :].partition("/")
        if not package or not relative:
            raise ChainConfigError(chain, key, f"{source!r}: expected package://<package>/<path>")
        path = share_directory(package) / relative
    else:
        path = Path(source).expanduser()
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ChainConfigError(chain, key, f"cannot read URDF {str(path)!r}: {exc.strerror or exc}") from None


def _vector(element, attribute: str, default: str, chain: str, where: str) -> np.ndarray:
    text = element.get(attribute, default) if element is not None else default
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise ChainConfigError(chain, "urdf", f"{where}: {attribute}={text!r} is not 3 numbers") from None
    if values.size != 3 or not np.all(np.isfinite(values)):
        raise ChainConfigError(chain, "urdf", f"{where}: {attribute}={text!r} is not 3 finite numbers")
    return values


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """4x4 rotation R_a with R_a z = a (a unit); identity for a = z."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, axis), float(z @ axis)
    frame = np.eye(4)
    if np.linalg.norm(v) < 1e-12:
        if c < 0.0:  # a = -z: half a turn about x
            frame[:3, :3] = np.diag([1.0, -1.0, -1.0])
        return frame
    skew = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    frame[:3, :3] = np.eye(3) + skew + skew @ skew / (1.0 + c)  # Rodrigues, z onto a
    return frame


def urdf_chain(name: str, source: str, base_link: str, tip_link: str, *, base=None, tool=None) -> Chain:
    """The Chain from ``base_link`` to ``tip_link`` of a URDF (see the module docstring);
    ChainConfigError naming the problem otherwise."""
    try:
        root = ET.fromstring(urdf_text(source, "urdf", name))
    except ET.ParseError as exc:
        raise ChainConfigError(name, "urdf", f"not valid XML: {exc}") from None
    if root.tag != "robot":
        raise ChainConfigError(name, "urdf", f"the root element is <{root.tag}>, expected <robot>")
    by_child = {}
    for joint in root.iter("joint"):
        child = joint.find("child")
        if child is not None and child.get("link"):
            by_child[child.get("link")] = joint
    links = {link.get("name") for link in root.iter("link")}
    for key, link in (("base_link", base_link), ("tip_link", tip_link)):
        if link not in links:
            raise ChainConfigError(name, key, f"link {link!r} is not in the URDF")
    path, link = [], tip_link
    while link != base_link:
        joint = by_child.get(link)
        if joint is None:
            raise ChainConfigError(name, "base_link", f"link {base_link!r} is not an ancestor of {tip_link!r}")
        path.append(joint)
        parent = joint.find("parent")
        link = parent.get("link") if parent is not None else None
    path.reverse()

    names, types, origins, lower, upper, mimics = [], [], [], [], [], []
    pending = np.eye(4)  # fixed transforms since the last moving joint (its R_a^T first)
    for joint in path:
        joint_name, kind = joint.get("name", "?"), joint.get("type")
        where = f"joint {joint_name!r}"
        origin = joint.find("origin")
        xyz = _vector(origin, "xyz", "0 0 0", name, where)
        rpy = _vector(origin, "rpy", "0 0 0", name, where)
        pending = pending @ xyz_rpy_matrix([*xyz, *rpy])
        if kind == "fixed":
            continue
        if kind not in _MOVING:
            raise ChainConfigError(
                name,
                "urdf",
                f"{where} is {kind!r}: a serial chain takes revolute, continuous, prismatic and fixed joints",
            )
        axis = _vector(joint.find("axis"), "xyz", "1 0 0", name, where)
        if np.linalg.norm(axis) < 1e-9:
            raise ChainConfigError(name, "urdf", f"{where} has a zero axis")
        turn = _axis_frame(axis / np.linalg.norm(axis))
        origins.append(pending @ turn)
        pending = turn.T.copy()
        pending[3] = (0.0, 0.0, 0.0, 1.0)
        names.append(joint_name)
        types.append(_MOVING[kind])
        if kind == "continuous":
            low, high = -math.pi, math.pi
        else:
            limit = joint.find("limit")
            if limit is None or limit.get("lower") is None or limit.get("upper") is None:
                raise ChainConfigError(name, "urdf", f"{where} ({kind}) needs <limit lower=... upper=...>")
            try:
                low, high = float(limit.get("lower")), float(limit.get("upper"))
            except ValueError:
                raise ChainConfigError(name, "urdf", f"{where}: limits are not numbers") from None
        lower.append(low)
        upper.append(high)
        mimic = joint.find("mimic")
        if mimic is not None:
            mimics.append((len(names) - 1, mimic, where))
    if not names:
        raise ChainConfigError(
            name, "urdf", f"no moving joint between {base_link!r} and {tip_link!r}: a chain needs at least one joint"
        )
    tip = pending if tool is None else pending @ tool
    couplings = []
    for index, mimic, where in mimics:
        leader = mimic.get("joint")
        if leader not in names:
            raise ChainConfigError(name, "urdf", f"{where} mimics {leader!r}, which is not on the chain")
        try:
            multiplier, offset = float(mimic.get("multiplier", "1")), float(mimic.get("offset", "0"))
        except ValueError:
            raise ChainConfigError(name, "urdf", f"{where}: mimic multiplier/offset are not numbers") from None
        coefficients = np.zeros(len(names))
        coefficients[names.index(leader)] = multiplier
        couplings.append(Coupling(index, offset, coefficients))
    zeros = [0.0] * len(names)
    return Chain(
        name,
        URDF,
        names,
        types,
        theta=zeros,
        a=zeros,
        lower=lower,
        upper=upper,
        base=base,
        tool=tip,
        couplings=couplings,
        joint_origins=origins,
    )
