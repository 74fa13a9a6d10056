"""ROS 2 message definitions for the MCAP export, one owner, and helpers that fill them.

:data:`DEFINITIONS` holds the fields (and constants) of every message the export writes and of
their dependencies, copied from the ``.msg`` files of ROS 2 Kilted (``std_msgs``,
``geometry_msgs``, ``sensor_msgs``, ``trajectory_msgs``, ``visualization_msgs`` 5.5.1,
``builtin_interfaces`` 2.3.0, ``tf2_msgs``) with their comments left out. :func:`msgdef` builds
the text rosbag2 stores as an MCAP ``ros2msg`` schema: the message's own fields, then each
dependency (depth first, once) after a line of ``=`` and a ``MSG: package/Name`` line.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin

from forte.validation import FloatArray

#: Fields of each message type (``package/Name``), as in its ``.msg`` file without comments.
DEFINITIONS: dict[str, str] = {
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec\n",
    "builtin_interfaces/Duration": "int32 sec\nuint32 nanosec\n",
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/String": "string data\n",
    "std_msgs/ColorRGBA": "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/Pose": "Point position\nQuaternion orientation\n",
    "geometry_msgs/Transform": "Vector3 translation\nQuaternion rotation\n",
    "geometry_msgs/TransformStamped": "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "sensor_msgs/JointState": ("std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
                               "float64[] effort\n"),
    "sensor_msgs/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data\n",
    "trajectory_msgs/JointTrajectory": "std_msgs/Header header\nstring[] joint_names\nJointTrajectoryPoint[] points\n",
    "trajectory_msgs/JointTrajectoryPoint": ("float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\n"
                                             "float64[] effort\nbuiltin_interfaces/Duration time_from_start\n"),
    "visualization_msgs/UVCoordinate": "float32 u\nfloat32 v\n",
    "visualization_msgs/MeshFile": "string filename\nuint8[] data\n",
    "visualization_msgs/MarkerArray": "Marker[] markers\n",
    "visualization_msgs/Marker": """\
int32 ARROW=0
int32 CUBE=1
int32 SPHERE=2
int32 CYLINDER=3
int32 LINE_STRIP=4
int32 LINE_LIST=5
int32 CUBE_LIST=6
int32 SPHERE_LIST=7
int32 POINTS=8
int32 TEXT_VIEW_FACING=9
int32 MESH_RESOURCE=10
int32 TRIANGLE_LIST=11
int32 ARROW_STRIP=12
int32 ADD=0
int32 MODIFY=0
int32 DELETE=2
int32 DELETEALL=3
std_msgs/Header header
string ns
int32 id
int32 type
int32 action
geometry_msgs/Pose pose
geometry_msgs/Vector3 scale
std_msgs/ColorRGBA color
builtin_interfaces/Duration lifetime
bool frame_locked
geometry_msgs/Point[] points
std_msgs/ColorRGBA[] colors
string texture_resource
sensor_msgs/CompressedImage texture
UVCoordinate[] uv_coordinates
string text
string mesh_resource
MeshFile mesh_file
bool mesh_use_embedded_materials
""",
}

#: ``visualization_msgs/Marker`` constants the export uses.
ARROW, CUBE, SPHERE, CYLINDER, TRIANGLE_LIST = 0, 1, 2, 3, 11
ADD, DELETE = 0, 2

_SEPARATOR = "=" * 80


def _dependencies(name: str) -> list[str]:
    """The message types ``name``'s fields use, in order (relative names within its package)."""
    package = name.split("/")[0]
    out = []
    for line in DEFINITIONS[name].splitlines():
        if "=" in line:  # a constant: type NAME=value
            continue
        field_type = re.sub(r"\[.*\]$", "", line.split()[0])
        if field_type[0].isupper():
            field_type = f"{package}/{field_type}"
        if "/" in field_type:
            out.append(field_type)
    return out


def msgdef(name: str) -> str:
    """The ``ros2msg`` schema text of ``name`` (``package/Name``) and its dependencies."""
    order: list[str] = []

    def visit(dep: str) -> None:
        for sub in _dependencies(dep):
            if sub not in order:
                order.append(sub)
                visit(sub)

    visit(name)
    parts = [DEFINITIONS[name]] + [f"{_SEPARATOR}\nMSG: {dep}\n{DEFINITIONS[dep]}" for dep in order]
    return "".join(parts)


def schema_name(name: str) -> str:
    """``package/msg/Name``: the name rosbag2 gives the schema of ``package/Name``."""
    package, base = name.split("/")
    return f"{package}/msg/{base}"


# -- values -----------------------------------------------------------------------------------
def nanoseconds(seconds: float) -> int:
    return int(round(seconds * 1e9))


def time(seconds: float) -> dict[str, int]:
    """``builtin_interfaces/Time`` (or ``Duration``) of ``seconds`` >= 0."""
    ns = nanoseconds(seconds)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def header(seconds: float, frame_id: str) -> dict:
    return {"stamp": time(seconds), "frame_id": frame_id}


def vector(v: FloatArray) -> dict[str, float]:
    """``geometry_msgs/Vector3`` or ``Point``."""
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def quaternion(R: FloatArray) -> dict[str, float]:
    """``geometry_msgs/Quaternion`` of a rotation matrix."""
    x, y, z, w = pin.Quaternion(np.asarray(R, dtype=float)).normalized().coeffs()
    return {"x": float(x), "y": float(y), "z": float(z), "w": float(w)}


def transform_stamped(seconds: float, parent: str, child: str, T: FloatArray) -> dict:
    """``geometry_msgs/TransformStamped``: ``child``'s pose ``T`` (4x4) in ``parent``."""
    return {"header": header(seconds, parent), "child_frame_id": child,
            "transform": {"translation": vector(T[:3, 3]), "rotation": quaternion(T[:3, :3])}}


def color(r: float, g: float, b: float, a: float = 1.0) -> dict[str, float]:
    return {"r": r, "g": g, "b": b, "a": a}


def marker(seconds: float, frame_id: str, ns: str, kind: int, *, action: int = ADD,
           position: FloatArray | None = None, rotation: FloatArray | None = None,
           scale: tuple[float, float, float] = (1.0, 1.0, 1.0), rgba: dict[str, float] | None = None,
           points: FloatArray | None = None) -> dict:
    """A ``visualization_msgs/Marker`` (id 0 in ``ns``, shown until replaced) at ``position`` with
    the orientation of ``rotation`` (3x3; default identity)."""
    p = np.zeros(3) if position is None else position
    R = np.eye(3) if rotation is None else rotation
    return {"header": header(seconds, frame_id), "ns": ns, "id": 0, "type": kind, "action": action,
            "pose": {"position": vector(p), "orientation": quaternion(R)},
            "scale": vector(scale), "color": rgba or color(1.0, 1.0, 1.0), "lifetime": time(0.0),
            "frame_locked": False, "points": [] if points is None else [vector(v) for v in points],
            "colors": [], "texture_resource": "", "texture": {"header": header(0.0, ""), "format": "", "data": b""},
            "uv_coordinates": [], "text": "", "mesh_resource": "", "mesh_file": {"filename": "", "data": b""},
            "mesh_use_embedded_materials": False}
