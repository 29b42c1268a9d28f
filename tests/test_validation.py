"""Bad input gets a clear error naming the parameter and what is allowed; failures never hand
back silent NaNs."""

import tempfile
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

import jaxbearing as jb
from jaxbearing import _checks
from jaxbearing.cli import config
from jaxbearing.multibody import (
    GROUND,
    Body,
    CircleContact,
    Mechanism,
    Revolute,
    SpringDamper,
    Translational,
)


def bearing(**kw):
    args = dict(
        clearance=4e-5,
        stiffness=9.57e9,
        damping=300.0,
        inner_race_diameter=29.2e-3,
        outer_race_diameter=46.6e-3,
        n_balls=8,
    )
    args.update(kw)
    return jb.BallBearing(**args)


def from_geometry(**kw):
    """The paper's SKF 98205 from its geometry, with ``kw`` changed."""
    args = dict(
        pitch_diameter=37.9e-3,
        ball_diameter=8.7e-3,
        n_balls=8,
        groove_inner=0.5219,
        groove_outer=0.5194,
        clearance=4e-5,
        damping=300.0,
        youngs_modulus=207e9,
        poisson_ratio=0.3,
    )
    args.update(kw)
    return jb.BallBearing.from_geometry(**args)


def impact_from_geometry(**kw):
    return jb.Impact.from_geometry(**{"radius_j": 0.01, "radius_k": 0.01, "restitution": 0.9, **kw})


def spring(stiffness=1e5, damping=120.0, free_length=0.1):
    return SpringDamper(GROUND, (0.1, 0.0), 0, (0.0, 0.0), stiffness, damping, free_length)


def pendulum(q0=(0.5, 0.0, 0.0), qd0=(0.0, 0.0, 0.0)):
    """A bar pinned to ground 0.5 m from its centroid."""
    return Mechanism([Body(1.0, 0.1)], [Revolute(GROUND, (0.0, 0.0), 0, (-0.5, 0.0))], list(q0), list(qd0))


def simulate_with(where, value):
    """0.005 s of the paper's case with one parameter set after construction (before these
    checks, a NaN ball stiffness had it run for more than 15 minutes): the compiled solve of
    tests/test_windows.py's short run, on the same worker (tests/conftest.py)."""
    return jb.simulate(eqx.tree_at(where, jb.cases.xu2014(), value), 0.005)


# (what is built, the whole message: parameter, allowed values and the value given)
BAD_INPUTS = [
    # masses and inertias
    (lambda: Body(0.0, 1.0), r"mass must be positive \[kg\]; got 0\."),
    (lambda: Body(1.0, -1.0), r"inertia must be positive \[kg m\^2\]; got -1\."),
    (lambda: jb.cases.rotor(bearing(), mass=-2.0), r"mass must be positive \[kg\]; got -2\."),
    # lengths
    (lambda: spring(free_length=0.0), r"free_length must be positive \[m\]; got 0\."),
    (lambda: CircleContact(0, (0.0, 0.0), 0.0, 1, (0.0, 0.0), 0.01, impact_from_geometry()),
     r"radius_j must be positive \[m\]; got 0\."),
    (lambda: impact_from_geometry(radius_k=-0.01), r"radius_k must be positive \[m\]; got -0\.01\."),
    (lambda: bearing(inner_race_diameter=0.0), r"inner_race_diameter must be positive \[m\]; got 0\."),
    # stiffnesses
    (lambda: bearing(stiffness=0.0), r"stiffness must be positive \[N/m\^n\]; got 0\."),
    (lambda: jb.Impact(-1e10, 0.9), r"stiffness must be positive \[N/m\^1\.5\]; got -1e\+10\."),
    (lambda: spring(stiffness=-1e5), r"stiffness must be zero or positive \[N/m\]; got -100000\."),
    # materials
    (lambda: from_geometry(youngs_modulus=0.0), r"youngs_modulus must be positive \[Pa\]; got 0\."),
    (lambda: impact_from_geometry(youngs_modulus=-207e9), r"youngs_modulus must be positive \[Pa\]; got -2\.07e\+11\."),
    (lambda: from_geometry(poisson_ratio=0.5), r"poisson_ratio must lie in \(0\.0, 0\.5\); got 0\.5\."),
    (lambda: from_geometry(poisson_ratio=-0.1), r"poisson_ratio must lie in \(0\.0, 0\.5\); got -0\.1\."),
    (lambda: impact_from_geometry(poisson_ratio=0.7), r"poisson_ratio must lie in \(0\.0, 0\.5\); got 0\.7\."),
    # bearing geometry
    (lambda: bearing(clearance=-1e-4), r"clearance must be at least -0\.01 of the ball diameter \(d_o - d_i\) / 2: a negative clearance is a preload.*\[m\]; got -0\.0001\."),
    (lambda: jb.cases.xu2014(clearance=-1e-4), r"clearance must be at least -0\.01 of the ball diameter \(d_o - d_i\) / 2: a negative clearance is a preload.*\[m\]; got -0\.0001\."),
    (lambda: jb.cases.xu2014(clearance=0.5),
     r"clearance must be at most 0\.1 of the ball diameter \(d_o - d_i\) / 2, far above any catalogue "
     r"clearance \[m\]; got 0\.5\."),
    (lambda: simulate_with(lambda m: m.bearing.clearance, 2e-3),
     r"^bearing\.clearance must be at most 0\.1 of the ball diameter .*; got 0\.002\."),
    (lambda: jb.BallBearing.from_catalogue("6205"), r"designation must be one of \['98205'\]; got '6205'\."),
    (lambda: bearing(n_balls=2), r"n_balls must be an integer of at least 3; got 2\."),
    (lambda: from_geometry(n_balls=2), r"n_balls must be an integer of at least 3; got 2\."),
    (lambda: from_geometry(ball_diameter=40e-3), r"pitch_diameter must exceed ball_diameter \[m\]; got 0\.0379\."),
    (lambda: from_geometry(n_balls=16),
     r"ball_diameter must be below pitch_diameter \* sin\(pi / n_balls\), or the balls overlap on the pitch circle \[m\]; got 0\.0087\."),
    (lambda: bearing(outer_race_diameter=20e-3),
     r"outer_race_diameter must exceed inner_race_diameter \[m\]; got 0\.02\."),
    (lambda: from_geometry(groove_inner=0.5), r"groove_inner \(inner raceway groove curvature ratio f_i = r_i/D\) must exceed 0\.5; got 0\.5\."),
    (lambda: from_geometry(groove_outer=0.45), r"groove_outer \(outer raceway groove curvature ratio f_o = r_o/D\) must exceed 0\.5; got 0\.45\."),
    (lambda: bearing(cage="free"), r"cage must be 'kinematic' or 'constant'; got 'free'\."),
    (lambda: bearing(ball_force="linear"), r"ball_force must be 'paper' or 'smooth'; got 'linear'\."),
    (lambda: bearing(exponent=1.0), r"exponent must be a finite number above 1 \(3/2 balls, 10/9 rollers\); got 1\.0\."),
    # restitution, damping, friction
    (lambda: jb.Impact(1e10, 0.0), r"restitution must lie in \(0\.0, 1\.0\]; got 0\."),
    (lambda: jb.cases.xu2014(restitution=1.5), r"restitution must lie in \(0\.0, 1\.0\]; got 1\.5\."),
    (lambda: bearing(damping=-1.0), r"damping must be zero or positive \[N s/m\]; got -1\."),
    (lambda: jb.cases.xu2014(bearing_damping=-300.0), r"damping must be zero or positive \[N s/m\]; got -300\."),
    (lambda: spring(damping=-120.0), r"damping must be zero or positive \[N s/m\]; got -120\."),
    (lambda: jb.Impact(1e10, 0.9, friction=-0.1), r"friction must be zero or positive \[-\]; got -0\.1\."),
    (lambda: jb.cases.xu2014(friction=-0.2), r"friction must be zero or positive \[-\]; got -0\.2\."),
    (lambda: jb.Impact(1e10, 0.9, friction_v0=1e-3, friction_v1=1e-4),
     r"friction_v1 must exceed friction_v0 \[m/s\]; got 0\.0001\."),
    # initial state
    # (the paper's crank moved 0.1 m off its pivot; turning 2 rad/s faster than its motor, its
    # centroid moving with it: simulate_with's compiled solve)
    (lambda: simulate_with(lambda m: m.q0, jb.cases.xu2014().q0.at[0].add(0.1)),
     r"initial positions q0 violate joint 0 \(Revolute, ground–crank\) at t0 by more than 1e-08 \(m or rad\); "
     r"model\.assemble\(q_guess, qd_guess, t0\) finds a consistent state; got 0\.1\."),
    (lambda: simulate_with(lambda m: m.qd0, jb.cases.xu2014().qd0.at[1].add(0.05).at[2].add(2.0)),
     r"initial velocities qd0 violate joint 1 \(Driver, crank\) at t0 by more than 1e-06 \(m/s or rad/s\); "
     r"model\.assemble\(q_guess, qd_guess, t0\) finds a consistent state; got 2\."),
    # assembly: a guess that cannot close, redundant joints, a pin beside a bearing
    (lambda: jb.Mechanism(jb.cases.four_bar().bodies, jb.cases.four_bar().joints[:3]
                          + (Revolute(GROUND, (0.9, 0.0), 2, (-0.125, 0.0)),), jb.cases.four_bar().q0,
                          forces=jb.cases.four_bar().forces, body_names=("crank", "coupler", "rocker")).assemble(),
     # which constraint is named depends on where the Gauss–Newton steps end, which for a loop
     # that cannot close is chaotic: the rounding of the compiled program decides it
     r"assembly could not close (joint \d \(Revolute|force \d \(BearingJoint), \w+–\w+\): its residual is "
     r"[\d.e+-]+ \(m or rad\) after "
     r"Gauss–Newton steps\. Start q_guess nearer an assembled position, or check the joints' points and the "
     r"links' lengths \(they may not close at all\)\."),
    (lambda: Mechanism([Body(1.0, 0.1)] * 2, [Revolute(GROUND, (0.0, 0.0), 0, (-0.5, 0.0))]
                       + [Revolute(0, (0.5, 0.0), 1, (-0.5, 0.0))] * 2, [0.4, 0.0, 0.0, 1.4, 0.0, 0.0]).assemble(),
     r"redundant constraints: joint 1 \(Revolute, body0–body1\), joint 2 \(Revolute, body0–body1\) constrain "
     r"the same motion \(Phi_q is rank-deficient at the assembly\)\. Remove one of them\."),
    (lambda: jb.Mechanism(jb.cases.four_bar().bodies, jb.cases.four_bar().joints
                          + (Revolute(2, (0.125, 0.0), 1, (0.14, 0.0)),), jb.cases.four_bar().q0,
                          forces=jb.cases.four_bar().forces, body_names=("crank", "coupler", "rocker")),
     r"joint 4 \(Revolute, rocker–coupler\) joins the two bodies of force 0 \(BearingJoint\) at the points it "
     r"centres: the ideal pin would carry the load and the BearingJoint none\. Remove the Revolute: the "
     r"BearingJoint is the joint\."),
    # time span
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.0),
     r"t1 must be greater than t0 = 0\.0 s; got t1 = 0\.0 s\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), -0.1),
     r"t1 must be greater than t0 = 0\.0 s; got t1 = -0\.1 s\."),
    # output times (checked before compiling)
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), jnp.inf), r"t1 must be a finite number \[s\]; got t1 = inf\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), float("nan")), r"t1 must be a finite number \[s\]; got t1 = nan\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, [0.0, 0.005, 0.002]),
     r"ts must be increasing \(equal neighbours allowed\) \[s\]; got ts\[2\] = 0\.002 after ts\[1\] = 0\.005\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, [-0.001, 0.005]),
     r"ts must lie within \[t0, t1\] = \[0\.0, 0\.01\] s; got ts\[0\] = -0\.001\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, [0.0, 0.011]),
     r"ts must lie within \[t0, t1\] = \[0\.0, 0\.01\] s; got ts\[1\] = 0\.011\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, [0.0, np.nan]), r"ts must be finite \[s\]; got ts\[1\] = nan\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, np.zeros((2, 3))),
     r"ts must be a 1-D array of at least one output time \[s\]; got shape \(2, 3\)\."),
    # step control (checked before compiling)
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, stepsize_controller=jb.default_controller(rtol=-1e-8)),
     r"rtol must be a finite number >= 0; got rtol = -1e-08\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, stepsize_controller=jb.default_controller(atol=np.nan)),
     r"atol must be a finite number >= 0; got atol = nan\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, stepsize_controller=jb.default_controller(rtol=0.0, atol=0.0)),
     r"rtol and atol must not both be zero: the step control needs one\."),
    (lambda: jb.default_controller(rtol=None), r"rtol must be a finite number >= 0; got rtol = None\."),
    (lambda: jb.default_controller(atol="1e-10"), r"atol must be a finite number >= 0; got atol = '1e-10'\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, max_steps=0),
     r"max_steps must be an integer of at least 1; got 0\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, max_steps=1e5),
     r"max_steps must be an integer of at least 1; got 100000\.0\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, progress=True),
     r"progress must be a label \(str\) or None; got True\."),
    # non-finite values: at construction, and set later by eqx.tree_at (an optimiser's step)
    (lambda: bearing(stiffness=np.nan), r"^stiffness must be finite \(not NaN or infinite\); got nan\."),
    (lambda: Body(np.inf, 1.0), r"^mass must be finite \(not NaN or infinite\); got inf\."),
    (lambda: jb.cases.xu2014(clearance=np.nan), r"^clearance must be finite \(not NaN or infinite\); got nan\."),
    (lambda: pendulum(qd0=(0.0, 0.0, np.nan)), r"qd0 must be finite \(not NaN or infinite\); got \[ 0\.  0\. nan\]\."),
    (lambda: simulate_with(lambda m: m.bearing.stiffness, jnp.nan),
     r"^bearing\.stiffness must be finite \(not NaN or infinite\); got nan\."),
    (lambda: simulate_with(lambda m: m.bearing.stiffness, np.inf),
     r"^bearing\.stiffness must be finite \(not NaN or infinite\); got inf\."),
    (lambda: simulate_with(lambda m: m.bearing.clearance, jnp.asarray(np.nan)),
     r"^bearing\.clearance must be finite \(not NaN or infinite\); got nan\."),
    (lambda: simulate_with(lambda m: m.bearing.clearance, np.inf),
     r"^bearing\.clearance must be finite \(not NaN or infinite\); got inf\."),
    (lambda: simulate_with(lambda m: m.bodies[1].mass, np.float64(np.nan)),
     r"bodies\.1\.mass must be finite \(not NaN or infinite\); got nan\."),
    (lambda: simulate_with(lambda m: m.bodies[1].mass, jnp.asarray(-np.inf)),
     r"bodies\.1\.mass must be finite \(not NaN or infinite\); got -inf\."),
    # bearing life ratings
    (lambda: jb.life.dynamic_load_rating(2, 8e-3, 39e-3), r"n_balls must be an integer of at least 3; got 2\."),
    (lambda: jb.life.dynamic_load_rating(9, -1e-3, 39e-3), r"ball_diameter must be positive \[m\]; got -0\.001\."),
    (lambda: jb.life.dynamic_load_rating(9, 8e-3, 7e-3), r"pitch_diameter must exceed ball_diameter \[m\]; got 0\.007\."),
    (lambda: jb.life.dynamic_load_rating(9, 8e-3, 39e-3, 1.6), r"contact_angle must lie in \[0, pi/2\) \[rad\]; got 1\.6\."),
    (lambda: jb.laws.hertz.bearing_stiffness(8.7e-3, 37.9e-3, 0.52, 0.52, 207e9, 0.3, -0.1),
     r"contact_angle must lie in \[0, pi/2\) \[rad\]; got -0\.1\."),
    (lambda: jb.life.dynamic_load_rating(20, 8e-3, 39e-3),
     r"ball_diameter must be below pitch_diameter \* sin\(pi / n_balls\), or the balls overlap on the pitch circle \[m\]; got 0\.008\."),
    # not a number: unit strings, numeric strings, booleans, None (SI numbers only)
    (lambda: jb.cases.xu2014(clearance="40 um"),
     r"clearance must be a number in SI units \[m\] \(a float or an array of floats\); got '40 um'\."),
    (lambda: jb.cases.xu2014(crank_speed="600 rpm"),
     r"speed must be a number in SI units \[rad/s\] \(a float or an array of floats\); got '600 rpm'\."),
    (lambda: jb.cases.xu2014(contact_on=None),
     r"active_from must be a number in SI units \[s\] \(a float or an array of floats\); got None\."),
    (lambda: bearing(damping="300"),
     r"damping must be a number in SI units \[N s/m\] \(a float or an array of floats\); got '300'\."),
    (lambda: jb.Impact(1e10, True),
     r"restitution must be a number in SI units \[-\] \(a float or an array of floats\); got True\."),
    (lambda: Body("1 kg", 0.1),
     r"mass must be a number in SI units \[kg\] \(a float or an array of floats\); got '1 kg'\."),
    (lambda: spring(free_length=[0.1, "m"]),
     r"free_length must be a number in SI units \[m\] \(a float or an array of floats\); got \[0\.1, 'm'\]\."),
    (lambda: from_geometry(ball_diameter="8.7 mm"),
     r"ball_diameter must be a number in SI units \[m\] \(a float or an array of floats\); got '8\.7 mm'\."),
    (lambda: jb.life.dynamic_load_rating(9, 8e-3, 39e-3, contact_angle="0 deg"),
     r"contact_angle must be a number in SI units \[rad\] \(a float or an array of floats\); got '0 deg'\."),
    # one number where a scalar parameter belongs; static settings finite
    (lambda: jb.cases.xu2014(clearance=[4e-5, 5e-5]), r"^clearance must be one number; got shape \(2,\)\."),
    (lambda: bearing(exponent=float("nan")),
     r"exponent must be a finite number above 1 \(3/2 balls, 10/9 rollers\); got nan\."),
    (lambda: bearing(n_balls=float("inf")), r"n_balls must be an integer of at least 3; got inf\."),
    # NaN geometry of the load ratings
    (lambda: jb.life.dynamic_load_rating(9, float("nan"), 39e-3),
     r"ball_diameter must be finite \(not NaN or infinite\); got nan\."),
    # a contact switched on while its surfaces overlap
    (lambda: jb.simulate(jb.cases.xu2014(contact_on=0.0), 0.005),  # the solve of simulate_with
     r"force 2 \(CircleContact, slider–target\) is switched on at t0 while its surfaces overlap "
     r"\(penetration \[m\]\): start it apart, "
     r"or switch it on later \(active_from\) when they are apart; got 0\.01\."),
    # window edges, a metric's coordinate
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, options=jb.SolveOptions(window_edges=0.005)),
     r"window_edges must be a tuple of finite times \[s\] \(e\.g\. \(0\.09,\)\); got 0\.005\."),
    (lambda: jb.metrics.max_target_displacement(_short_solution(), coordinate=-2),
     r"coordinate must be None \(the impact target's x\) or an index into q, an integer >= 0; got -2\."),
    (lambda: jb.metrics.max_target_displacement(_short_solution(), coordinate=12),
     r"coordinate must be an index into q, an integer in \[0, 12\); got 12\."),
    (lambda: jb.metrics.peak_ball_load(_short_solution(), t_min=8e-4, t_max=2e-4),
     r"t_max must exceed t_min; got the window \[0\.0008, 0\.0002\] s\."),
    (lambda: jb.metrics.peak_ball_load(_short_solution(), [0.0, 1e-3]),
     r"t_min must be a time \[s\], one number, the window's start, \"model\" \(the model's "
     r"window_start\) or None \(from t0\); got \[0\.0, 0\.001\]\."),
    (lambda: jb.metrics.peak_ball_load(_short_solution(), 0.0, "1 ms"),
     r"t_max must be a time \[s\], one number, the window's end, or None \(to the end of the run\); "
     r"got '1 ms'\."),
    (lambda: jb.metrics.peak_time(_short_solution(), "peak_ball_load"),
     r"metric must be an exact peak \(the metric, not its name\): an ElementPeak or CoordinatePeak, e\.g\. "
     r"jaxbearing\.metrics\.peak_ball_load, peak_bearing_force, peak_impact_force or "
     r"max_target_displacement, or one of them \.replace\(\.\.\.\)d; got the string 'peak_ball_load'\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, stepsize_controller=jb.default_controller(rtol=10.0)),
     r"rtol must be below 1 \(a relative error\); got rtol = 10\.0\."),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01,
                         stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=-1.0)),
     r"atol must be a finite number >= 0; got atol = -1\.0\."),
    # step-size control: StepTo refused, a constant step needs dt0, dt0 a step within the span
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01,
                         stepsize_controller=diffrax.StepTo(ts=np.linspace(0.0, 0.01, 11))),
     r"stepsize_controller=diffrax\.StepTo is not supported: its grid of step ends cannot survive the "
     r"restarts of the solve at its events .* simulate supports diffrax\.PIDController \(e\.g\. "
     r"jaxbearing\.default_controller\(rtol, atol\)\) and diffrax\.ConstantStepSize\(\) with its step in "
     r"jaxbearing\.SolveOptions\(dt0=\.\.\.\)"),
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, stepsize_controller=diffrax.ConstantStepSize()),
     r"stepsize_controller=diffrax\.ConstantStepSize\(\) needs its step: set it in "
     r"jaxbearing\.SolveOptions\(dt0=\.\.\.\) \[s\]"),
    *[(lambda dt0=dt0: jb.simulate(jb.cases.xu2014(impact=False), 0.01, options=jb.SolveOptions(dt0=dt0)),
       rf"dt0 must be a finite step \[s\] above 0 and below t1 - t0 = 0\.01 s; got dt0 = {shown}\.")
      for dt0, shown in ((0.0, r"0\.0"), (-1e-6, r"-1e-06"), (np.nan, "nan"), (np.inf, "inf"), (0.01, r"0\.01"))],
    (lambda: jb.simulate(jb.cases.xu2014(impact=False), 0.01, options=jb.SolveOptions(dt0="1 us")),
     r"dt0 must be one number, a step \[s\]; got '1 us'\."),
    # parameter paths: one parameter named twice, a static setting, a non-positive scale
    (lambda: jb.paths.replace(jb.cases.xu2014(), {"bearing.clearance": 1e-5, "forces.0.bearing.clearance": 2e-5}),
     r"Parameter paths 'bearing\.clearance' and 'forces\.0\.bearing\.clearance' name the same parameter; give it once\."),
    (lambda: jb.sensitivity(jb.cases.xu2014(), jb.metrics.peak_ball_load, ["bearing.n_balls"], 0.01),
     r"Parameter 'bearing\.n_balls' must be a scalar array leaf of the model to be differentiated; got int \."),
    (lambda: jb.tune(lambda m: 0.0, jb.cases.xu2014(), ["bearing.clearance"], optax.adam(0.1), 1,
                     scale={"bearing.clearance": -4e-5}),
     r"scale of bearing\.clearance must be a finite number > 0 \(in its units\); got -4e-05\."),
    # configuration files: not UTF-8 (named), a huge value (echoed cut short)
    (lambda: config.read_overrides(_config_file('[bearing]\ncage = "k\xe9"\n'.encode("latin-1"))),
     r"overrides\.toml is not UTF-8 text \(byte 19 is b'\\xe9'\): a TOML file must be UTF-8; save it "
     r"with that encoding\."),
    (lambda: config.check_overrides({"bearing": {"cage": "x" * 20_000_000}}),
     r"^configuration: bearing\.cage must be one of 'kinematic', 'constant'; got the string "
     r"'x{79}\.\.\. \(20000002 characters\)\.$"),
    # sweeps check their span and output times before running anything
    (lambda: jb.sweep(jb.cases.xu2014(impact=False), {"bearing.clearance": [4e-5]}, t1=float("inf")),
     r"t1 must be a finite number \[s\]; got t1 = inf\."),
    (lambda: jb.sweep(jb.cases.xu2014(impact=False), {"bearing.clearance": [4e-5]}, t1=0.01, ts=[0.0, np.nan]),
     r"ts must be finite \[s\]; got ts\[1\] = nan\."),
    (lambda: jb.sweep(jb.cases.xu2014(impact=False), {"bearing.clearance": [4e-5, 2e-5, 4e-5]}, t1=0.05),
     r"bearing\.clearance repeats \[4e-05\]: the values of a grid axis label its results and must differ "
     r"\(grid=False takes a list of points, repeats allowed\)\."),
    (lambda: jb.sweep(jb.cases.xu2014(impact=False), {"bearing.clearance": [4e-5]}, t1=0.03),
     r"The standard metrics read the model's window from t = 0\.04 s \(model\.window_start\), which "
     r"t1 = 0\.03 s does not reach: simulate longer, or pass metrics with an earlier t_min"),
]


def _config_file(data: bytes):
    """A configuration file holding ``data``, in a new temporary folder."""
    path = Path(tempfile.mkdtemp()) / "overrides.toml"
    path.write_bytes(data)
    return path


def _short_solution():
    # the compiled solve of simulate_with, of the tests of values changed after construction and
    # of solver failures (the paper's case with its contact, switched on at 0.05 s)
    return jb.simulate(jb.cases.xu2014(), 0.005, jnp.linspace(0.0, 0.005, 3))


@pytest.mark.parametrize("make, message", BAD_INPUTS)
def test_bad_input_is_rejected_naming_parameter_range_and_value(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def _two_bearings():
    """A disc held by two bearing joints (no solve: its rules are read on the host)."""
    joints = [jb.multibody.BearingJoint(GROUND, (0.0, 0.0), 0, (0.0, 0.0), bearing()) for _ in range(2)]
    return Mechanism([Body(2.0, 2e-3)], [], [0.0, 0.0, 0.0], forces=joints)


def test_a_solve_names_each_parameter_by_a_path_that_reads_it():
    """Inside a solve a parameter is named as `jb.paths` reads it: every floating leaf's name is
    a path that `jb.paths.get` follows back to that very leaf, through ``bearing`` and
    ``impact`` on the paper's case and through ``bearings.1`` on a model with two bearing
    joints, whose rules name the second one's clearance so."""
    for model in (jb.cases.xu2014(), _two_bearings()):
        for path, leaf in jax.tree_util.tree_leaves_with_path(model):
            name = jb.paths.typed(model, jax.tree_util.keystr(path, simple=True, separator="."))
            assert jb.paths.get(model, name) is leaf, name
    assert jb.paths.typed(jb.cases.xu2014(), "forces.0.bearing.clearance") == "bearing.clearance"
    assert jb.paths.typed(jb.cases.xu2014(), "forces.2.impact.restitution") == "impact.restitution"
    bad = eqx.tree_at(lambda m: m.bearings[1].bearing.clearance, _two_bearings(), -1e-4)
    with pytest.raises(ValueError, match=r"^bearings\.1\.bearing\.clearance must be at least -0\.01 of the ball diameter .*; got -0\.0001\.$"):
        _checks.raise_first(bad.parameter_violations(np))



def test_parameter_paths_list_both_forms_and_a_bad_path_is_refused_with_them():
    """`parameter_paths` lists every leaf by its general path (``bearings.i.``, ``contacts.j.``),
    which docs/mechanisms.md recommends, and, on a model with one bearing or contact, by the short
    path as well (before, only ``impact.restitution``, not ``contacts.0.impact.restitution``);
    each reads its leaf. A path the model lacks is refused with that list by the sweep and by
    `jb.sensitivity` alike (whose message listed nothing)."""
    model = jb.cases.xu2014()
    listed = jb.paths.parameter_paths(model)
    for general, short in (("contacts.0.impact.restitution", "impact.restitution"),
                           ("bearings.0.bearing.clearance", "bearing.clearance")):
        assert listed.index(short) == listed.index(general) + 1
        assert jb.paths.get(model, general) is jb.paths.get(model, short)
    assert "bearings.0.outer_point" in listed and "contacts.0.active_from" in listed
    assert not any(p.startswith("forces.0.") for p in listed)  # the bearing joint is bearings.0
    assert len(listed) == len(set(listed))
    leaves = {id(leaf) for leaf in jax.tree_util.tree_leaves(model) if eqx.is_array(leaf)}
    assert {id(jb.paths.get(model, p)) for p in listed} == leaves
    two = jb.paths.parameter_paths(_two_bearings())
    assert "bearings.1.bearing.clearance" in two and "bearing.clearance" not in two
    message = r"Parameter path 'bearing.clearnce' does not exist in the model .* Its parameters: .*contacts\.0\.impact\.restitution"
    with pytest.raises(ValueError, match=message):
        jb.sensitivity(model, jb.metrics.peak_ball_load, ["bearing.clearnce"], 0.06)
    with pytest.raises(ValueError, match=message):
        jb.sweep(model, {"bearing.clearnce": [4e-5]}, t1=0.06)


def test_a_window_edge_off_the_stops_is_nan_under_jit():
    """Traced, the edge cannot be checked in Python: NaN, never an approximate number (a sweep
    marks such a member failed with the reason; called on a concrete solution, the metric
    raises it)."""
    value = jax.jit(jb.metrics.peak_ball_load)(_short_solution(), 5e-4)
    assert np.isnan(float(value))
    with pytest.raises(ValueError, match=r"needs its edges to be ends of the solution's stop intervals"):
        jb.metrics.peak_ball_load(_short_solution(), 5e-4)


def test_overconstrained_mechanism_is_rejected():
    with pytest.raises(ValueError, match="over-determine"):
        Mechanism(
            [Body(1.0, 0.1)],
            [Translational(0), Translational(0, line_angle=1.0)],
            [0.0] * 3,
            [0.0] * 3,
        )


def test_values_changed_after_construction_are_checked_in_simulate():
    """eqx.tree_at bypasses constructors: simulate checks the values again."""
    model = eqx.tree_at(lambda m: m.bearing.clearance, jb.cases.xu2014(), -1e-4)
    with pytest.raises(Exception, match="bearing.clearance must be at least -0.01 of the ball diameter"):
        jb.simulate(model, 0.005, jnp.linspace(0.0, 0.005, 3))  # the compiled solve of simulate_with


def _run_with_clearance(c):
    m = eqx.tree_at(lambda m: m.bearing.clearance, jb.cases.xu2014(impact=False), c)
    return jb.simulate(m, 1e-4, jnp.linspace(0.0, 1e-4, 3)).q


@pytest.mark.slow  # 20 s: a vmapped compile of the paper's case
@pytest.mark.parametrize(
    "bad, message",
    [(-1e-4, "bearing.clearance must be at least -0.01 of the ball diameter"), (np.nan, "bearing.clearance must be finite")],
)
def test_traced_bad_values_are_checked_under_vmap(bad, message):
    with pytest.raises(Exception, match=message):
        jax.vmap(_run_with_clearance)(jnp.array([4e-5, bad]))


def test_initial_state_is_checked_at_t0():
    """The crank's driver turns it at a fixed speed from t = 0: q0 is consistent at t0 = 0, not
    at t0 = 5 ms, and a run started there would drift by the crank's turn since t = 0."""
    model = jb.cases.xu2014()
    with pytest.raises(Exception, match=r"initial positions q0 violate joint 1 \(Driver, crank\) at t0"):
        # the compiled solve of simulate_with (the same span; t0 is a value of it)
        jb.simulate(model, 0.01, jnp.linspace(0.005, 0.01, 3), options=jb.SolveOptions(t0=0.005))


def test_a_contact_switched_on_while_overlapping_is_an_error():
    """The paper's circles overlap at 1 ms: the event value jumps from -1 (off) to +10 mm (on)
    there, which the event's root finder reports as a jump, and the switch as an error."""
    with pytest.raises(Exception, match=r"a contact switched on \(its active_from\) while its surfaces overlap"):
        jb.simulate(jb.cases.xu2014(contact_on=0.001), 0.005)  # the compiled solve of simulate_with


def test_traced_nan_output_times_are_checked():
    ts = jnp.array([0.0, 0.004, jnp.nan, 0.01])
    with pytest.raises(Exception, match=r"ts must be finite, increasing and lie within \[t0, t1\]"):
        jax.jit(lambda ts: jb.simulate(jb.cases.xu2014(impact=False), 0.01, ts).q)(ts)


def test_traced_non_finite_times_are_checked():
    from jaxbearing.solve import checked_span as _checked_span

    with pytest.raises(Exception, match=r"t0 and t1 must be finite \[s\]"):
        jax.jit(lambda t1: _checked_span(0.0, t1)[1])(jnp.inf)
    assert jax.jit(lambda t1: _checked_span(0.0, t1)[1])(0.5) == 0.5


def test_solver_failure_raises_with_time_and_advice():
    model = jb.cases.xu2014()
    with pytest.raises(jb.SimulationError, match=r"stopped at t = .* s of t1 = 0.005 s.*max_steps"):
        jb.simulate(model, 0.005, max_steps=5)  # the compiled solve of simulate_with


def test_solver_failure_without_throw_reports_and_marks_nan():
    model = jb.cases.xu2014()
    sol = jb.simulate(model, 0.005, max_steps=5, throw=False)  # the solve of the test above
    ts = sol.ts
    assert sol.result == jb.RESULTS.max_steps_reached
    assert 0.0 < float(sol.t_final) < 0.005
    after = np.asarray(ts) > float(sol.t_final)
    assert np.isnan(np.asarray(sol.q)[after]).all()
    assert np.isnan(np.asarray(sol.ball_loads)[after]).all()
    assert np.isfinite(np.asarray(sol.q)[~after]).all()


@pytest.mark.slow  # 14 s; tests/test_pauses.py runs out of segments by default
def test_too_few_segments_fails_loudly():
    model = jb.cases.xu2014(impact=True)
    with pytest.raises(jb.SimulationError, match="max_segments"):
        jb.simulate(model, 0.1, jnp.linspace(0.0, 0.1, 11), options=jb.SolveOptions(max_segments=3))


def test_float32_mode_is_refused(monkeypatch):
    monkeypatch.setattr(jax.config, "read", lambda name: False)
    with pytest.raises(RuntimeError, match="jax_enable_x64"):
        Body(1.0, 1.0)
