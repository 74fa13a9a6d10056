"""The task file's sections about what the robot carries and what surrounds it
(:mod:`forte.planning.tasks.task_fields` says how a field is declared): ``payload``
(:data:`PAYLOAD_FIELDS`), a given ``force`` profile (:data:`FORCE_FIELDS`), a ``contact`` task
(:data:`CONTACT_FIELDS`), the ``scene``'s bodies, shapes and sensed entries, and the ``floor``
(:data:`SCENE_FIELDS`). The readers: :mod:`forte.planning.tasks.payload_section`,
:mod:`forte.planning.tasks.contact_section`, :mod:`forte.planning.tasks.scene_section`,
:mod:`forte.planning.tasks.sensed_section`."""

from __future__ import annotations

from forte.force.contact import CONTACT_KINDS
from forte.force.payload import MAX_COM_OFFSET_M
from forte.model.occupancy_cover import DEFAULT_MAX_BOXES, DEFAULT_SLACK, DEFAULT_SLACK_VOXELS
from forte.model.scene import SHAPE_KINDS
from forte.planning.tasks.contact_section import (
    MAX_BOX_SIZE,
    MAX_DAMPING,
    MAX_FRICTION,
    MAX_FRICTION_FORCE,
    MAX_STIFFNESS,
)
from forte.planning.tasks.scene_section import MAX_LENGTH_M
from forte.planning.tasks.sensed_section import DEFAULT_MAX_RANGE, DEFAULT_VOXEL, MAX_BOXES, MAX_SLACK, MAX_VOXEL
from forte.planning.tasks.task_types import (
    DURATION,
    INERTIA,
    MAPPING,
    MASS,
    SINE,
    STRING,
    VEC3,
    ZERO3,
    Field,
    Prose,
    choice,
    either,
    integer,
    number,
    vector,
)
from forte.validation import MAX_DURATION_S, MAX_MASS_KG

LENGTH = number(above=0, high=MAX_LENGTH_M)

PAYLOAD_FIELDS = [
    Field("payload.mass", number(low=0, high=MAX_MASS_KG), "the payload's mass (--mass overrides it; 0: an empty "
          "hand)", "kg"),
    Field("payload.description", STRING, "words for the mass estimator (forte estimate)"),
    Field("payload.image", STRING, "an image for the mass estimator (PNG, JPEG, WebP or GIF; relative to the task "
          "file)"),
    Field("payload.com", vector(3, norm=MAX_COM_OFFSET_M), "the payload's centre of mass in the end-effector frame",
          "m", Prose("at the hand")),
    Field("payload.inertia", INERTIA, "the payload's inertia about its centre of mass, end-effector axes", "kg m^2",
          Prose("none")),
    Field("payload.moment_scale", number(above=0, high=MAX_COM_OFFSET_M), "length that scales moments against "
          "forces in the wrench metric", "m", Prose("|com|")),
]

CONSTANT = ("kind", "constant")
FORCE_FIELDS = [
    Field("force.kind", choice(("constant", "windowed-sine")), "how the profile is given", default="constant"),
    Field("force.vector", VEC3, "the constant force", "N", required=True, when=CONSTANT),
    Field("force.duration", DURATION, "the window's length (at least the path's)", "s", Prose("the path's span"),
          when=SINE),
    Field("force.offset", VEC3, "c in w(t) (c + a sin(2 pi f t + phi))", "N", ZERO3, when=SINE),
    Field("force.amplitude", VEC3, "a in w(t) (c + a sin(2 pi f t + phi))", "N", required=True, when=SINE),
    Field("force.frequency", VEC3, "f in w(t) (c + a sin(2 pi f t + phi))", "Hz", required=True, when=SINE),
    Field("force.phase", VEC3, "phi in w(t) (c + a sin(2 pi f t + phi))", "rad", ZERO3, when=SINE),
]

PUSH, DRAWER, CARRY = (("kind", k) for k in CONTACT_KINDS)
CONTACT_FIELDS = [
    Field("contact.kind", choice(CONTACT_KINDS), "the contact model (forte.force.contact)", required=True),
    Field("contact.mass", MASS, "the box's, drawer's or carried object's mass", "kg", required=True),
    Field("contact.friction", number(above=0, high=MAX_FRICTION), "the box's friction coefficient on the floor",
          required=True, when=PUSH),
    Field("contact.size", vector(3, above=0, high=MAX_BOX_SIZE), "the box's edge lengths", "m", [0.4, 0.4, 0.4],
          when=PUSH),
    Field("contact.stiffness", number(low=0, high=MAX_STIFFNESS), "the drawer's spring", "N/m", 0.0, when=DRAWER),
    Field("contact.damping", number(low=0, high=MAX_DAMPING), "the drawer's damper", "N s/m", 0.0, when=DRAWER),
    Field("contact.friction", number(low=0, high=MAX_FRICTION_FORCE), "the drawer's Coulomb friction", "N", 0.0,
          when=DRAWER),
    Field("contact.rest", number(), "the drawer spring's rest position along the path", "m", 0.0, when=DRAWER),
    Field("contact.com", vector(3, norm=MAX_COM_OFFSET_M), "the object's centre of mass in the end-effector frame",
          "m", required=True, when=CARRY),
    Field("contact.partner", vector(3, norm=MAX_COM_OFFSET_M), "the partner's grip in the end-effector frame", "m",
          required=True, when=CARRY),
    Field("contact.share", number(low=0, high=1.0), "the weight's share the hand carries",
          default=Prose("from com and partner"), when=CARRY),
    Field("contact.release_time", number(low=0, high=MAX_DURATION_S), "when the partner lets go", "s",
          Prose("never"), when=CARRY),
    Field("contact.release_duration", DURATION, "how long the release takes", "s", 0.5, when=CARRY),
]

_SHAPES = {
    "box": [Field("scene[].box.size", vector(3, above=0, high=MAX_LENGTH_M), "edge lengths", "m", required=True)],
    "cylinder": [Field("scene[].cylinder.radius", LENGTH, "radius", "m", required=True),
                 Field("scene[].cylinder.length", LENGTH, "length along its z axis", "m", required=True)],
    "sphere": [Field("scene[].sphere.radius", LENGTH, "radius", "m", required=True)],
    "capsule": [Field("scene[].capsule.radius", LENGTH, "radius", "m", required=True),
                Field("scene[].capsule.length", LENGTH, "length of its axis along z", "m", required=True)],
    "mesh": [Field("scene[].mesh.file", STRING, "a mesh file (STL, OBJ, ...; relative to the task file)",
                   required=True),
             Field("scene[].mesh.scale", either(number(above=0), vector(3, above=0)), "scale factors (one or x, y, z)",
                   default=1.0)],
}
_VOXEL = number(above=0, high=MAX_VOXEL)


def _merge(kind: str) -> list[Field]:
    """The sensed entry's ``merge`` (:func:`forte.planning.tasks.sensed_section.merge_settings`)."""
    return [Field(f"scene[].{kind}.merge", either(choice(("exact",)), MAPPING), "how the occupied voxels become "
                  "boxes: exact (their union is the voxels) or a coarse cover {slack, max_boxes} (boxes holding "
                  "every voxel and free space only within slack of one)", default=Prose("the cover's defaults")),
            Field(f"scene[].{kind}.merge.slack", number(low=0, high=MAX_SLACK), "the cover's boxes stay within "
                  "this of an occupied voxel (until max_boxes)", "m",
                  Prose(f"{DEFAULT_SLACK_VOXELS} voxels, at least {DEFAULT_SLACK:g} m")),
            Field(f"scene[].{kind}.merge.max_boxes", integer(1, MAX_BOXES), "the most boxes of the cover",
                  default=DEFAULT_MAX_BOXES)]


_SENSED = [
    Field("scene[].capture_configuration", vector(), "the robot's whole-body configuration when the sensor "
          "data was taken: points on the robot are removed (point_cloud, depth_image only)", "m, m, rad, rad...",
          Prose("no self-filter")),
    Field("scene[].point_cloud", MAPPING, "a point cloud whose occupied voxels become boxes"),
    Field("scene[].point_cloud.file", STRING, "a .ply, .pcd or .npy (N x 3) file (relative to the task file)",
          required=True),
    Field("scene[].point_cloud.voxel", _VOXEL, "voxel size", "m", DEFAULT_VOXEL),
    *_merge("point_cloud"),
    Field("scene[].depth_image", MAPPING, "a depth image (pose: the camera's optical frame, z forward, x right, "
          "y down) whose occupied voxels become boxes"),
    Field("scene[].depth_image.file", STRING, "a .png (grey) or .npy (H x W) file (relative to the task file)",
          required=True),
    Field("scene[].depth_image.scale", number(above=0), "metres per image unit",
          default=Prose("0.001 for .png, 1 for .npy")),
    Field("scene[].depth_image.intrinsics", MAPPING, "the pinhole camera: fx, fy, cx, cy (pixels)", required=True),
    *(Field(f"scene[].depth_image.intrinsics.{k}", number(above=0) if k[0] == "f" else number(), what, "px",
            required=True) for k, what in (("fx", "focal length along x"), ("fy", "focal length along y"),
                                           ("cx", "principal point's column"), ("cy", "principal point's row"))),
    Field("scene[].depth_image.max_range", number(above=0, high=1000.0), "depths beyond it are no return", "m",
          DEFAULT_MAX_RANGE),
    Field("scene[].depth_image.voxel", _VOXEL, "voxel size", "m", DEFAULT_VOXEL),
    *_merge("depth_image"),
]
SCENE_FIELDS = [
    Field("scene[].name", STRING, "the body's name (unique)", default=Prose("body<i>")),
    Field("scene[].pose", vector(6), "x, y, z, roll, pitch, yaw in the world", "m, rad", required=True),
    *(f for kind in SHAPE_KINDS for f in [Field(f"scene[].{kind}", MAPPING, f"a {kind} (exactly one shape per "
                                                "body)"), *_SHAPES[kind]]),
    *_SENSED,
    Field("floor.height", number(low=-MAX_LENGTH_M, high=MAX_LENGTH_M), "the floor's height (world z)", "m",
          required=True),
]


__all__ = ["CONTACT_FIELDS", "FORCE_FIELDS", "PAYLOAD_FIELDS", "SCENE_FIELDS"]
