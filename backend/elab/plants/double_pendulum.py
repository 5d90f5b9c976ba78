"""Rotary double inverted pendulum, seed §4.2 (eq. 4.7).

States :math:`x = [\\alpha, \\beta_1, \\beta_2, \\dot\\alpha, \\dot\\beta_1,
\\dot\\beta_2]` as deviations from the linearisation point (pendulum 1 upright,
:math:`\\beta_1 = 0`; pendulum 2 hanging, :math:`\\beta_2 = 180°`). Predefined
LQR with Q = diag(100, 5e9, 5e9, 1, 1, 1), R = 100 (seed §4.2.3).

The seed's input gain is small (B ≈ 0.03) and its LQR gain large (≈ 17 500 V/rad
on β1): holding 10° of β1 asks for hundreds of volts. A ±10 V amplifier would
lose the pendulum, so this plant's runs do not saturate by default; the limit
stays available and documented (docs/plants.md).
"""

from __future__ import annotations

import math

from elab.laws import OpenLoop, StateFeedback
from elab.plants.base import (
    Channel,
    IdentDefaults,
    LessonStep,
    Plant,
    Sensors,
    SignalDefaults,
    VelocityFilter,
    frozen_matrix,
)
from elab.plants.flexible_link import ENCODER_QUANTUM

STATES = (
    Channel("alpha", "rad", "disc angle α"),
    Channel("beta1", "rad", "pendulum 1 angle β₁ from upright"),
    Channel("beta2", "rad", "pendulum 2 angle β₂ from upright"),
    Channel("alpha_dot", "rad/s", "disc speed α̇"),
    Channel("beta1_dot", "rad/s", "pendulum 1 rate β̇₁"),
    Channel("beta2_dot", "rad/s", "pendulum 2 rate β̇₂"),
)

#: the predefined controller: the chapter's LQR (seed §4.2)
LQR = StateFeedback(K=(-1.0, 17549.1681, -4772.05208, -32.9730917, 3063.80861, 756.623012))
#: pendulum 1 released 0.5° from upright, the rest at the operating point
RELEASED = (0.0, math.radians(0.5), math.pi, 0.0, 0.0, 0.0)

PLANT = Plant(
    id="double_pendulum",
    name="Rotary double pendulum",
    summary="Two pendulums on a rotating arm: balance the upper one upright.",
    A=frozen_matrix(
        [
            [0, 0, 0, 1, 0, 0],
            [0, 0, 0, 0, 1, 0],
            [0, 0, 0, 0, 0, 1],
            [0, 4.2017, 1.7791, -0.3247, -0.0222, 0.0095],
            [0, 28.1858, 0.8197, -0.1496, -0.1486, 0.0044],
            [0, -2.9100, -40.6937, 0.2249, 0.0153, -0.2162],
        ]
    ),
    B=frozen_matrix([[0], [0], [0], [0.0302], [0.0139], [-0.0209]]),
    C=frozen_matrix([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]]),
    D=frozen_matrix([[0], [0], [0]]),
    states=STATES,
    inputs=(Channel("u", "V", "motor voltage u"),),
    outputs=STATES[:3],  # the outputs measure the first 3 states
    u_max=10.0,
    saturate=False,
    Ts=0.001,
    reference_output=0,
    reference_state=0,
    predefined=LQR,
    predefined_design="LQR, Q = diag(100, 5e9, 5e9, 1, 1, 1), R = 100",
    sensors=Sensors(quantum=(ENCODER_QUANTUM,) * 3, noise_std=(2e-4,) * 3),
    # the loop's slowest poles (−0.06 ± 0.04j) bring the disc within 2 % of a step after
    # 114 s (the run lasts a tenth longer: tests/unit/test_plant_defaults.py); pendulum 1
    # released 0.5° from upright shows the balancing: the disc swings about 45° to catch
    # it, both pendulums move by about half a degree
    signal=SignalDefaults(
        kind="step",
        amplitude=math.radians(10),
        duration=130.0,
        x0=RELEASED,
    ),
    operating_point=frozen_matrix([[0, 0, math.pi, 0, 0, 0]])[0],
    initial_state_ranges=(
        (1, math.radians(-10), math.radians(10)),
        (2, math.radians(150), math.radians(210)),
    ),
    velocity_filters=(
        VelocityFilter(3, 0, 100.0),
        VelocityFilter(4, 1, 100.0),
        VelocityFilter(5, 2, 100.0),
    ),
    identification=IdentDefaults(
        models="n4sid:6",
        why="Six states, one of them unstable (pendulum 1 upright): subspace with its order "
        "given, and its unstable pole kept (an order chosen automatically, and the choice to "
        "reflect the pole, are judged by simulations, which grow with the unstable mode). "
        "Choose all outputs where they move: pendulum 1's angle carries the unstable mode. "
        "Under the predefined LQR with the realistic sensors the pendulums move a few "
        "encoder counts at most (β₂ may not move one, and is then refused by name) and the "
        "verdicts call the data and the model poor; with ideal sensors and all three "
        "outputs the six poles come out exactly.",
    ),
    notes=(
        "There is no hardware for this plant, only its linearised model: identification "
        "here runs on that model, in closed loop.",
    ),
    # the chapter's pendulum in three runs (seed §4.2), each from pendulum 1 released 0.5°
    # from upright: nothing holds it, the arbitrary gain k = [10 … 10] (Fig. 4.31), the LQR
    lesson=(
        LessonStep(
            "The plant alone",
            "Open loop, no voltage: pendulum 1, released half a degree from upright, falls "
            "and leaves the linear model's range within a second.",
            OpenLoop(),
            SignalDefaults(kind="step", amplitude=0.0, duration=1.0, x0=RELEASED),
        ),
        LessonStep(
            "An arbitrary gain",
            "State feedback with the chapter's arbitrary k = [10 10 10 10 10 10]: the "
            "loop is unstable: the pendulum falls as if nothing held it, while the "
            "controller asks for more than the actuator's ±10 V.",
            StateFeedback(K=(10.0,) * 6),
            SignalDefaults(kind="step", amplitude=0.0, duration=1.0, x0=RELEASED),
        ),
        LessonStep(
            "The LQR design",
            "The predefined LQR catches the falling pendulum: the disc swings about 45° "
            "and both pendulums stay within a degree of upright. It asks for up to 153 V: "
            "saturation is off for this model, a real motor would not follow.",
            LQR,
            SignalDefaults(kind="step", amplitude=0.0, duration=20.0, x0=RELEASED),
        ),
    ),
)
