"""A lever lifted by one muscle over a cam: a mechanism file (model-spec 3b, docs/mechanisms.md).

The muscle's lower end wraps a cam on the lever's axle whose radius grows with the angle, so the
length is L = L_top - r0 phi - k_cam phi^2 / 2 and the moment arm -dL/dphi = r0 + k_cam phi (mkctl
differentiates it). The lever (3 kg, centre of mass 0.2 m from the axle) hangs down at phi = 0;
gravity pulls it back.
"""


def lengths(q, p, xp):
    """The muscle's length [m] at the lever angle q [rad]."""
    return (p.L_top - p.r0 * q - 0.5 * p.k_cam * q**2,)


def inertia(q, p, xp):
    """The lever's moment of inertia about its axle [kg m^2]."""
    return p.J_lever


def load(q, qdot, p, xp):
    """Gravity's torque and the axle's viscous friction [N m]."""
    return -p.m_lever * p.g * p.l_lever * xp.sin(q) - p.c_joint * qdot


def stops(p):
    """The lever's end stops [rad]."""
    return (p.q_low, p.q_high)


MECHANISM = {
    "name": "cam_lever",
    "description": "a lever lifted by one muscle over a cam",
    "coordinate": {"name": "phi", "unit": "rad"},
    "muscles": ["muscle"],
    "parameters": [
        {"name": "L_top", "unit": "m", "default": 0.2, "lower": 0.05, "upper": 1.0},
        {"name": "r0", "unit": "m", "default": 0.02, "lower": 0.001, "upper": 0.2},
        {"name": "k_cam", "unit": "m/rad", "default": 0.01, "lower": 0.0, "upper": 0.1},
        {"name": "J_lever", "unit": "kg m^2", "default": 0.15, "lower": 1e-5, "upper": 10.0},
        {"name": "m_lever", "unit": "kg", "default": 3.0, "lower": 0.0, "upper": 100.0},
        {"name": "l_lever", "unit": "m", "default": 0.2, "lower": 0.0, "upper": 2.0},
        {"name": "c_joint", "unit": "N m s/rad", "default": 0.05, "lower": 0.0, "upper": 10.0},
        {"name": "q_low", "unit": "rad", "default": -0.3, "lower": -3.0, "upper": 3.0},
        {"name": "q_high", "unit": "rad", "default": 1.2, "lower": -3.0, "upper": 3.0},
    ],
    "lengths": lengths, "inertia": inertia, "load": load, "stops": stops,
}
