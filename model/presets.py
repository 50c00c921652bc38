"""Ready linkages: the paper's six-link anthropoid and relatives.

``six_link_anthropoid`` is exactly the canonical scene of ``shared/scene.md`` (names,
numbering, parameters): 1 stance shank (from H0), 2 stance thigh (to the hip H2), 3 swing
thigh, 4 swing shank, 5 torso, 6 head, with J about each centre of mass.
"""

from __future__ import annotations

from dataclasses import replace

from model.anthropometry import FOOT_COM, FootGeometry
from model.linkage import Link, Linkage
from model.points import LinkPoint
from planner.errors import DefinitionError, DefinitionTypeError, check_positive, check_real

#: The scene.md table: name, parent, l (m), m (kg), n, J (kg m^2).
SIX_LINK_TABLE: tuple[tuple[str, str | None, float, float, float, float], ...] = (
    ("stance_shank", None, 0.43, 3.3, 0.57, 0.05),
    ("stance_thigh", "stance_shank", 0.43, 7.0, 0.57, 0.12),
    ("swing_thigh", "stance_thigh", 0.43, 7.0, 0.43, 0.12),
    ("swing_shank", "swing_thigh", 0.43, 3.3, 0.43, 0.05),
    ("torso", "stance_thigh", 0.50, 34.0, 0.55, 0.90),
    ("head", "torso", 0.25, 5.3, 0.50, 0.03),
)

_FIELDS = ("length", "mass", "com", "inertia")


def six_link_anthropoid(gravity: float = 9.81, **overrides) -> Linkage:
    """The paper's six-link branched mechanism with the scene.md parameters.

    Overrides change one parameter of one link: ``six_link_anthropoid(torso_mass=40.0,
    head_com=0.6)``; the key is ``<link name>_<length|mass|com|inertia>``.
    """
    values = {
        name: {"length": l, "mass": m, "com": n, "inertia": j}
        for name, _, l, m, n, j in SIX_LINK_TABLE
    }
    for key, value in overrides.items():
        for name in values:
            prefix = name + "_"
            if key.startswith(prefix) and key[len(prefix) :] in _FIELDS:
                values[name][key[len(prefix) :]] = value
                break
        else:
            raise DefinitionError(
                f"`{key}`: unknown override; use <link>_<field> with link in "
                f"{[row[0] for row in SIX_LINK_TABLE]} and field in {list(_FIELDS)}"
            )
    links = [Link(name, parent, **values[name]) for name, parent, *_ in SIX_LINK_TABLE]
    return Linkage(links, gravity=gravity)


def five_link_biped(gravity: float = 9.81) -> Linkage:
    """The six-link scene without the head: two legs and a torso meeting at the hip."""
    return six_link_anthropoid(gravity=gravity).drop("head")


def anthropoid_with_feet(gravity: float = 9.81, foot: FootGeometry | None = None) -> Linkage:
    """The six-link scene on feet: eight links, the stance foot the root.

    The scene's six links unchanged (Winter's table for a person of 1.75 m and 70 kg, see
    :mod:`model.anthropometry`) and a foot on each leg from the same table (``foot``, default
    ``FootGeometry()``: 1.015 kg each, 0.16 m from the ankle to the ball, the ankle 0.068 m
    above the sole). Order: stance_foot, stance_shank, stance_thigh, swing_thigh,
    swing_shank, swing_foot, torso, head.

    The root is the stance foot, described from the ball of the foot (H0, the toe contact:
    where the foot pivots when the heel rises) to the ankle; the stance shank starts at the
    ankle. The swing foot runs from its ankle to its ball (its end), so the legs are mirror
    images and ``model.swap_legs`` re-roots at the swing foot's ball. The heel and toe
    contacts of both feet: :func:`anthropoid_feet`.
    """
    foot = FootGeometry() if foot is None else foot
    if not isinstance(foot, FootGeometry):
        raise DefinitionTypeError(
            f"`foot`: must be a model.anthropometry.FootGeometry, got {type(foot).__name__}"
        )
    legs = six_link_anthropoid(gravity=gravity).links
    # Winter's centre of mass lies 0.50 of the way from the ankle to the ball: 1 - 0.50 from
    # the ball, where the stance foot starts.
    mass, inertia = foot.segment_mass, foot.inertia
    feet = {
        "stance_foot": Link("stance_foot", None, foot.segment, mass, 1.0 - FOOT_COM, inertia),
        "swing_foot": Link("swing_foot", "swing_shank", foot.segment, mass, FOOT_COM, inertia),
    }
    links = [feet["stance_foot"]]
    for link in legs:
        # the scene's root, the stance shank, stands on the stance foot's end (the ankle)
        links.append(replace(link, parent="stance_foot") if link.parent is None else link)
        if link.name == "swing_shank":
            links.append(feet["swing_foot"])
    return Linkage(links, gravity=gravity)


#: The body of the six-link scene: Winter's table for a person of this height, m, and mass, kg.
SCENE_HEIGHT, SCENE_MASS = 1.75, 70.0


def scaled_body(linkage: Linkage, height: float, body_mass: float) -> Linkage:
    """``linkage`` (a body of :data:`SCENE_HEIGHT` and :data:`SCENE_MASS`, as the presets
    are) for a person of ``height`` m and ``body_mass`` kg by the same anthropometric table
    (Winter's segment lengths are fractions of the height, masses fractions of the body
    mass, radii of gyration fractions of the segment): lengths and origins x height / 1.75,
    masses x body_mass / 70, inertias x (body_mass / 70) (height / 1.75)^2; gravity and the
    fractions (centres of mass, contact points on links) unchanged."""
    height = check_positive("height", height, "m")
    body_mass = check_positive("body_mass", body_mass, "kg")
    length, mass = height / SCENE_HEIGHT, body_mass / SCENE_MASS
    converted = linkage.in_units(length=length, mass=mass)  # gravity x length: put it back
    return Linkage(converted.links, gravity=linkage.gravity)


def anthropoid_feet(foot: FootGeometry | None = None) -> dict[str, LinkPoint]:
    """The contacts of :func:`anthropoid_with_feet`: ``stance_toe`` (H0, the ball),
    ``stance_heel``, ``swing_heel``, ``swing_toe`` (the swing foot's end), as points of the
    foot links named after them."""
    foot = FootGeometry() if foot is None else foot
    stance_heel = foot.point_on_link(foot.heel, from_ankle=False)
    swing_heel = foot.point_on_link(foot.heel, from_ankle=True)
    return {
        "stance_toe": LinkPoint("stance_foot", 0.0, 0.0, name="stance_toe"),
        "stance_heel": LinkPoint("stance_foot", *stance_heel, name="stance_heel"),
        "swing_heel": LinkPoint("swing_foot", *swing_heel, name="swing_heel"),
        "swing_toe": LinkPoint("swing_foot", 1.0, 0.0, name="swing_toe"),
    }


def n_link_chain(
    n: int,
    length: float = 1.0,
    mass: float = 1.0,
    com: float = 0.5,
    inertia: float | None = None,
    gravity: float = 9.81,
) -> Linkage:
    """A serial chain of ``n`` identical links named link1..linkn (an n-link pendulum)."""
    if isinstance(n, bool) or not isinstance(n, int):
        raise DefinitionTypeError(f"`n`: must be an integer number of links, got {n!r}")
    if n < 1:
        raise DefinitionError(f"`n`: must be >= 1 link, got {n}")
    check_real("length", length)
    links = [
        Link(f"link{i + 1}", None if i == 0 else f"link{i}", length, mass, com, inertia)
        for i in range(n)
    ]
    return Linkage(links, gravity=gravity)


def exoskeleton_leg(
    body_mass: float = 75.0,
    height: float = 1.75,
    gravity: float = 9.81,
) -> Linkage:
    """A three-link exoskeleton leg hanging from a fixed hip: thigh, shank, foot.

    The hip is H0 (the support frame of a test rig); segment lengths, masses, centre-of-mass
    fractions and radii of gyration scale with body mass and height (Winter's anthropometric
    table, Biomechanics and Motor Control of Human Movement, table 4.1): thigh 0.245 H,
    0.100 M, n 0.433, radius of gyration 0.323 l; shank 0.246 H, 0.0465 M, n 0.433, 0.302 l;
    foot (heel to toe) 0.152 H, 0.0145 M, n 0.50, 0.475 l.
    """
    body_mass = check_positive("body_mass", body_mass, "kg")
    height = check_positive("height", height, "m")
    rows = (
        ("thigh", None, 0.245, 0.100, 0.433, 0.323),
        ("shank", "thigh", 0.246, 0.0465, 0.433, 0.302),
        ("foot", "shank", 0.152, 0.0145, 0.50, 0.475),
    )
    links = []
    for name, parent, length_ratio, mass_ratio, com, gyration in rows:
        length = length_ratio * height
        mass = mass_ratio * body_mass
        links.append(Link(name, parent, length, mass, com, mass * (gyration * length) ** 2))
    return Linkage(links, gravity=gravity)


PRESETS = {
    "six-link": six_link_anthropoid,
    "five-link": five_link_biped,
    "exoskeleton-leg": exoskeleton_leg,
    "six-link-feet": anthropoid_with_feet,
}
