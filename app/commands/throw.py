"""``python -m app throw CONFIG [--json] [--verify]``: a VHC throw of the throwing arm;
``python -m app throw --optimize [--seed N] [--evaluations N] [--budget SECONDS]``: the longest throw
under every limit (the budget is counted in throw evaluations; seconds are only an optional cap);
``python -m app throw --thesis``: the thesis's numbers beside the lab's;
``python -m app throw CONFIG --closed-loop {open,vhc,transverse,all} [--plant FILE] [--monte-carlo N]``:
the throw in full dynamics under feedback on a plant that differs from the model (docs/throwing.md);
``python -m app throw [CONFIG] --optimize --robust [--plant heavier] [--closed-loop transverse] [--monte-carlo 50]``:
the robust objective (5 % quantile of the distance over N plants, limits held in >= 95 % of them).

JSON output of a throw (a stable contract, keys are only ever added): theta_dot_e [m/s], duration [s],
release_position [x, y] (m, y above the ground), release_velocity [vx, vy] (m/s, J(q) q'),
distance_from_base, distance_from_release [m] (true velocity), distance_from_base_thesis,
distance_from_release_thesis [m] (the thesis's convention: speed theta_dot along psi), feasible,
violations (list of strings), max_speed_ratio [3] (max |q_i'| / limit), max_torque [2] (max |tau_i|,
N m), plus release_velocity_thesis, release_speed, release_angle_deg, q_release, dq_release, model
(parameter values used) and config (the throw, normalized). See docs/cli.md.
"""
from __future__ import annotations

import json
import math
import sys

import yaml

NAME = "throw"
MAX_BUDGET_S = 3600.0
MAX_EVALUATIONS = 1_000_000
HELP = "throws of the throwing arm: evaluate a VHC throw, optimize one, or reproduce the thesis"


def add_arguments(p):
    p.add_argument("config", nargs="?", help="throw file (YAML or JSON) or a shipped throw (throw1, throw2, throw3)")
    p.add_argument("--json", action="store_true", help="print one JSON object (stable format)")
    p.add_argument("--verify", action="store_true",
                   help="also simulate the full 3-DOF arm (feedforward and computed torque) and report the drift")
    p.add_argument("--optimize", action="store_true", help="search the longest throw under every limit")
    p.add_argument("--seed", type=int, default=0, help="random seed of the optimizer (default 0)")
    p.add_argument("--evaluations", type=int, default=None,
                   help="optimizer budget in throw evaluations (default 12000): the same seed gives the same throw "
                        "on any machine")
    p.add_argument("--budget", type=float, default=None,
                   help="optional extra cap on the optimizer's time in seconds (reported when it ends the search)")
    p.add_argument("--objective", choices=("thesis", "physical"), default="thesis",
                   help="distance to maximize: thesis convention (theta_dot along psi, default) or true velocity")
    p.add_argument("--degree", type=int, default=6, help="Bezier degree for the optimizer (default 6)")
    p.add_argument("--out", help="with --optimize: write the best throw to this YAML file")
    p.add_argument("--thesis", action="store_true", help="the thesis's numbers beside the lab's")
    p.add_argument("--robot", default="throwing_arm", help="robot file with the throwing arm's structure")
    p.add_argument("--closed-loop", choices=("open", "vhc", "transverse", "all"),
                   help="simulate the throw in full dynamics under a controller: the plan's torques open loop, "
                        "VHC enforcement (feedback linearization + PD) or the transverse LQR stabilizer")
    p.add_argument("--plant", default=None,
                   help="plant file (YAML/JSON) or a shipped plant (exact, heavier) for --closed-loop (default exact) "
                        "and --robust (default heavier)")
    p.add_argument("--catch", action="store_true",
                   help="with --closed-loop (one controller): the catching arm catches the ball, planned from a noisy "
                        "camera's view of the flight")
    p.add_argument("--camera-noise", type=float, default=None,
                   help="with --catch: standard deviation of the camera's ball positions [m] (default 0.005)")
    p.add_argument("--camera-rate", type=float, default=None, help="with --catch: pictures per second (default 100)")
    p.add_argument("--catcher", choices=("full", "kinematic"), default="full",
                   help="with --catch: the catching arm simulated in its full dynamics under computed torque "
                        "(default) or following its planned motion exactly (kinematic, as in the coursework)")
    p.add_argument("--monte-carlo", type=int, metavar="N",
                   help="with --closed-loop: N plants drawn from the plant file's uncertainty ranges (seed: --seed); "
                        "with --robust: the plants of the robust objective (default 50)")
    p.add_argument("--robust", action="store_true",
                   help="with --optimize: the robust objective: the 5 %% quantile of the landing distance over N "
                        "plants (--monte-carlo N, --plant, --closed-loop controller), limits held in >= 95 %% of them; "
                        "--evaluations counts robust evaluations (default 60), from CONFIG (default optimized_thesis)")


def _floats(values, digits=10):
    return [round(float(v), digits) for v in values]


def throw_json(arm, throw, feasibility) -> dict:
    rel = throw.release
    return {
        "theta_dot_e": throw.theta_dot_e,
        "duration": throw.duration,
        "release_position": _floats(rel.position),
        "release_velocity": _floats(rel.velocity),
        "distance_from_base": rel.distance_from_base,
        "distance_from_release": rel.distance_from_release,
        "distance_from_base_thesis": rel.distance_from_base_thesis,
        "distance_from_release_thesis": rel.distance_from_release_thesis,
        "feasible": feasibility.feasible,
        "violations": feasibility.violations,
        "max_speed_ratio": _floats(feasibility.max_speed_ratio),
        "max_torque": _floats(feasibility.max_torque),
        "release_velocity_thesis": _floats(rel.velocity_thesis),
        "release_speed": rel.speed,
        "release_angle_deg": rel.angle_deg,
        "q_release": _floats(rel.q),
        "dq_release": _floats(rel.dq),
        "model": arm.values,
        "config": throw.spec.to_config(),
    }


def verification_json(sim) -> dict:
    rel = sim.release
    return {"controller": sim.controller, "duration": sim.duration, "theta_dot_e": rel.theta_dot,
            "max_wrist_drift": sim.max_wrist_drift, "max_ball_drift": sim.max_ball_drift,
            "max_theta_dot_error": sim.max_theta_dot_error,
            "distance_from_base": rel.distance_from_base, "distance_from_base_thesis": rel.distance_from_base_thesis,
            "max_torque": _floats(abs(sim.tau).max(axis=1))}


def _progress(enabled):
    if not enabled:
        return None
    state = {"last": -1.0}

    def report(fraction, message):
        if fraction - state["last"] >= 0.05 or fraction >= 1.0:
            state["last"] = fraction
            print(f"[{100 * fraction:3.0f}%] {message}", file=sys.stderr, flush=True)
    return report


def _print_throw(cfg_title, arm, throw, feas, thesis, sims) -> None:
    rel = throw.release
    ref = lambda key, fmt: f"   (thesis: {thesis[key]:{fmt}})" if key in thesis else ""
    print(cfg_title or "throw")
    print(f"  theta_dot at release    {throw.theta_dot_e:.4f} m/s{ref('theta_dot_e', '.4g')}")
    print(f"  duration                {throw.duration:.4f} s{ref('duration', '.4g')}")
    print(f"  release point           x = {rel.position[0]:.5f} m, y = {rel.position[1]:.5f} m above the ground")
    print(f"  ball velocity J(q) q'   {rel.speed:.4f} m/s at {rel.angle_deg:.2f} deg "
          f"(thesis convention: {rel.theta_dot:.4f} m/s at psi = {throw.spec.psi_deg:.3f} deg)")
    print(f"  distance from the base  {rel.distance_from_base:.4f} m; thesis convention "
          f"{rel.distance_from_base_thesis:.4f} m{ref('distance_from_base', '.3g')}")
    print(f"  from the release point  {rel.distance_from_release:.4f} m; thesis convention "
          f"{rel.distance_from_release_thesis:.4f} m{ref('distance_from_release', '.3g')}")
    print("  max speed / limit       " + "  ".join(f"{r:.4f}" for r in feas.max_speed_ratio))
    print("  max |torque|            " + "  ".join(f"{t:.2f}" for t in feas.max_torque) + " N m")
    print(f"  feasible (Table A.2)    {'yes' if feas.feasible else 'no'}")
    for v in feas.violations:
        print(f"    - {v}")
    for sim in sims:
        print(f"  full 3-DOF simulation ({sim.controller}): wrist drift {sim.max_wrist_drift:.2e} rad, ball drift "
              f"{sim.max_ball_drift:.2e} m, theta_dot(theta) error {sim.max_theta_dot_error:.2e} (relative), "
              f"thesis-convention distance {sim.release.distance_from_base_thesis:.4f} m")


def _thesis(args, arm) -> int:
    from app.core.throw.thesis import thesis_comparison

    rows = thesis_comparison(arm)
    if args.json:
        json.dump(rows, sys.stdout)
        sys.stdout.write("\n")
        return 0
    print("The thesis (Lillehammer, NTNU 2014) beside the lab (robot file: reading B of Appendix A)")
    for r in rows:
        thesis = "-" if r["thesis"] is None else r["thesis"]
        lab = "rejected" if r["lab"] is None else r["lab"]
        print(f"  {r['quantity']}: thesis {thesis}, lab {lab}" + (f"  [{r['note']}]" if r["note"] else ""))
    return 0


def _optimize(args, arm) -> int:
    from app.core.errors import UserError
    from app.core.throw.optimize import DEFAULT_EVALUATIONS, ThrowOptimizer, speed_limit_bound
    from app.core.throw.simulation import simulate_full
    from app.core.throw.thesis import hand_estimate

    if args.budget is not None and not 0 < args.budget <= MAX_BUDGET_S:
        raise UserError(f"--budget must be positive and at most {MAX_BUDGET_S:g} seconds")
    evaluations = DEFAULT_EVALUATIONS if args.evaluations is None else args.evaluations
    if not 1 <= evaluations <= MAX_EVALUATIONS:
        raise UserError(f"--evaluations must be a whole number from 1 to {MAX_EVALUATIONS}")
    opt = ThrowOptimizer(arm, degree=args.degree, objective=args.objective)
    res = opt.run(seed=args.seed, evaluations=evaluations, max_seconds=args.budget, progress=_progress(not args.json))
    sims = [simulate_full(res.throw, c) for c in ("feedforward", "computed_torque")]
    other = speed_limit_bound(arm, "physical" if args.objective == "thesis" else "thesis", seed=args.seed)
    bounds = {res.bound.convention: res.bound.distance_from_base, other.convention: other.distance_from_base}
    est = hand_estimate(arm)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            yaml.safe_dump({"title": f"optimized throw (seed {args.seed}, objective {args.objective})",
                            **res.spec.to_config()}, fh, sort_keys=False)
    if args.json:
        out = {"objective": res.objective, "distance_from_base": res.distance_from_base,
               "config": res.spec.to_config(), "result": throw_json(arm, res.throw, res.feasibility),
               "speed_limit_bound": bounds, "hand_estimate": {"speed": est.speed, "distance_from_base":
                                                              est.distance_from_base},
               "verification": [verification_json(s) for s in sims], "evaluations": res.evaluations,
               "local_runs": res.local_runs, "elapsed": res.elapsed,
               "evaluations_per_second": res.evaluations / res.elapsed,
               "evaluation_budget": res.evaluation_budget, "time_capped": res.time_capped,
               "time_cap": args.budget, "seed": args.seed,
               "evaluations_to_best": res.evaluation_history[-1][0] if res.evaluation_history else None}
        json.dump(out, sys.stdout)
        sys.stdout.write("\n")
        return 0
    print(f"optimized throw ({res.objective} convention, seed {args.seed}), {res.evaluations} of "
          f"{res.evaluation_budget} throw evaluations in {res.elapsed:.1f} s, {res.local_runs} local runs")
    if res.time_capped:
        print(f"  the time cap of {args.budget:g} s ended the search: this result depends on the machine's speed")
    print(f"  distance from the base  {res.distance_from_base:.4f} m; the joint speed limits alone allow "
          f"{res.bound.distance_from_base:.4f} m (hand estimate of the thesis: {est.distance_from_base:.3f} m)")
    print("  config: " + json.dumps(res.spec.to_config()))
    _print_throw("", arm, res.throw, res.feasibility, {}, sims)
    return 0


def _robust_value_json(v) -> dict:
    num = lambda x: float(x) if math.isfinite(x) else None
    return {"score": num(v.score), "distance_q05": num(v.distance_q05), "held_rate": v.held_rate,
            "ratio_q95": num(v.ratio_q95), "robust": v.robust}


def _optimize_robust(args, arm, cfg) -> int:
    from app.core.errors import UserError
    from app.core.throw.plants import load_plant
    from app.core.throw.robust import DEFAULT_PLANTS, DEFAULT_ROBUST_EVALUATIONS, RobustOptimizer
    from app.core.throw.arm import ThrowingArm
    from app.core.throw.config import load_throw_config

    evaluations = DEFAULT_ROBUST_EVALUATIONS if args.evaluations is None else args.evaluations
    if not 1 <= evaluations <= 100000:
        raise UserError("--evaluations (robust evaluations) must be a whole number from 1 to 100000")
    if args.closed_loop == "all":
        raise UserError("--robust needs one controller (--closed-loop open, vhc or transverse)")
    if args.budget is not None:
        raise UserError("--robust counts its budget in evaluations only (leave out --budget)")
    controller = args.closed_loop or "transverse"
    plants = DEFAULT_PLANTS if args.monte_carlo is None else args.monte_carlo
    plant = load_plant(args.plant or "heavier")
    start = (cfg or load_throw_config("optimized_thesis")).spec
    if cfg is None:
        arm = ThrowingArm(args.robot, load_throw_config("optimized_thesis").model)
    opt = RobustOptimizer(arm, plant, controller, plants=plants, seed=args.seed, degree=len(start.a) - 1)
    res = opt.run(start, evaluations, progress=_progress(not args.json))
    feas = res.throw.check()
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            yaml.safe_dump({"title": f"robust throw (seed {args.seed}, {controller}, {plants} plants of "
                                     f"{plant.title})", **res.spec.to_config()}, fh, sort_keys=False)
    robust = {"controller": controller, "plant": plant.to_config(), "plants": plants, "seed": args.seed,
              **_robust_value_json(res.value), "start": _robust_value_json(res.start),
              "evaluations_to_best": res.evaluation_history[-1][0]}
    if args.json:
        out = {"objective": "robust", "distance_from_base": res.throw.release.distance_from_base,
               "config": res.spec.to_config(), "result": throw_json(res.throw.arm, res.throw, feas),
               "evaluations": res.evaluations, "evaluation_budget": evaluations, "seed": args.seed, "robust": robust}
        json.dump(out, sys.stdout)
        sys.stdout.write("\n")
        return 0
    v, s0 = res.value, res.start
    print(f"robust throw (seed {args.seed}): {res.evaluations} robust evaluations, each {plants} plants of "
          f"'{plant.title}' under {controller}")
    for label, x in (("start", s0), ("best", v)):
        print(f"  {label:5s} 5 % quantile of the distance {x.distance_q05:.4f} m, limits held in "
              f"{100 * x.held_rate:.0f} % of the plants (95 % quantile of the worst limit ratio {x.ratio_q95:.3f})"
              + ("" if x.robust else "; not robust"))
    print(f"  plan: {res.throw.release.distance_from_base:.4f} m from the base on the model")
    print("  config: " + json.dumps(res.spec.to_config()))
    return 0


def closed_loop_json(run, planned_distance: float, j: int = 0) -> dict:
    """One plant's closed-loop throw (docs/cli.md)."""
    released = bool(run.released[j])
    num = lambda a: float(a[j]) if released else None
    vec = lambda a: _floats(a[:, j]) if released else None
    return {"controller": run.controller, "released": released, "release_time": num(run.release_time),
            "theta_dot_e": num(run.theta_dot_e), "release_speed": num(run.release_speed),
            "release_position": vec(run.release_position), "release_velocity": vec(run.release_velocity),
            "distance_from_base": num(run.distance), "distance_from_base_thesis": num(run.distance_thesis),
            "landing_error": float(run.distance[j] - planned_distance) if released else None,
            "max_speed_ratio": _floats(run.max_speed_ratio[:, j]),
            "max_torque_ratio": _floats(run.max_torque_ratio[:, j]),
            "position_violation": bool(run.position_violation[j]), "violation": bool(run.violation[j])}


def _catch(args, throw, plant, names) -> dict:
    from app.core.errors import UserError
    from app.core.throw.catch import CAMERA_NOISE, CAMERA_RATE, throw_and_catch

    if len(names) != 1:
        raise UserError("--catch needs one controller (--closed-loop open, vhc or transverse)")
    noise = CAMERA_NOISE if args.camera_noise is None else args.camera_noise
    rate = CAMERA_RATE if args.camera_rate is None else args.camera_rate
    r = throw_and_catch(throw, plant, names[0], rate=rate, noise=noise, seed=args.seed, catcher_mode=args.catcher)
    vec = lambda a: None if a is None else _floats(a)
    run = r.run
    out = {"controller": r.controller, "success": r.success, "miss": r.miss if r.catch_time is not None else None,
           "message": r.message, "catch_time": r.catch_time, "catch_point": vec(r.catch_point), "hand": vec(r.hand),
           "ball": vec(r.ball), "catcher_base": [r.base_x, 0.0], "camera_rate": rate, "camera_noise": noise,
           "camera_pictures": int(r.camera_times.size), "release_position": vec(r.release_position),
           "release_velocity": vec(r.release_velocity), "estimated_release_velocity": vec(r.estimate.v0),
           "catcher": r.catcher, "q_catch_planned": vec(r.q_catch), "q_catch": vec(r.q_end),
           "catcher_tracking_error": None if run is None else run.tracking_error,
           "catcher_hand_tracking_error": None if run is None else run.hand_tracking_error,
           "catcher_max_torque": None if run is None else _floats(run.max_torque),
           "catcher_torque_limits": None if run is None or run.torque_limits is None else _floats(run.torque_limits),
           "catcher_saturated": None if run is None else run.saturated,
           "catcher_energy_error": None if run is None else run.energy_error,
           "catcher_position_violation": None if run is None else run.position_violation}
    if not args.json:
        print(f"plant: {plant.title}; thrown with {r.controller}, camera {rate:g} pictures/s, noise {1e3 * noise:g} mm")
        print(f"  {r.message}" + (f" at t = {r.catch_time:.3f} s after the release" if r.catch_time else ""))
        if run is not None:
            print(f"  catching arm in full dynamics (computed torque): tracking error <= {1e3 * run.tracking_error:.2f} mrad "
                  f"({1e3 * run.hand_tracking_error:.2f} mm at the hand), max |tau| "
                  + " ".join(f"{x:.1f}" for x in run.max_torque) + " N m"
                  + ("; torques saturated" if run.saturated else ""))
        elif r.catch_time is not None:
            print("  catching arm kinematic: it follows its planned motion exactly")
    return out


def _closed_loop(args, throw) -> dict:
    from app.core.errors import UserError
    from app.core.throw.closed_loop import CONTROLLERS, simulate_closed_loop
    from app.core.throw.plants import load_plant
    from app.core.throw.montecarlo import format_summary, monte_carlo

    plant = load_plant(args.plant or "exact")
    names = list(CONTROLLERS) if args.closed_loop == "all" else [args.closed_loop]
    planned = throw.release.distance_from_base
    out = {"plant": plant.to_config(), "planned_distance_from_base": planned,
           "planned_release_speed": throw.release.speed}
    if args.monte_carlo is not None:
        if not 1 <= args.monte_carlo <= 100000:
            raise UserError("--monte-carlo must be between 1 and 100000 plants")
        study = monte_carlo(throw, plant, names, args.monte_carlo, seed=args.seed,
                            progress=_progress(not args.json))
        out["monte_carlo"] = {"plants": study.plants, "seed": study.seed,
                              "controllers": {n: study.summary(n) for n in names}}
        if not args.json:
            print(f"plant: {plant.title}")
            print(format_summary(study))
        return out
    if args.catch:
        return {**out, "catch": _catch(args, throw, plant, names)}
    runs = [simulate_closed_loop(throw, n, plant, seed=args.seed) for n in names]
    out["runs"] = [closed_loop_json(r, planned) for r in runs]
    if not args.json:
        print(f"plant: {plant.title}; planned landing {planned:.4f} m from the base, release speed "
              f"{throw.release.speed:.4f} m/s")
        for r in out["runs"]:
            if not r["released"]:
                print(f"  {r['controller']:10s} the ball never reaches theta_e")
                continue
            print(f"  {r['controller']:10s} lands {r['distance_from_base']:.4f} m (error {r['landing_error']:+.4f} m), "
                  f"release speed {r['release_speed']:.4f} m/s, max speed/limit "
                  + " ".join(f"{x:.3f}" for x in r["max_speed_ratio"])
                  + ", max |tau|/limit " + " ".join(f"{x:.3f}" for x in r["max_torque_ratio"])
                  + ("; limits violated" if r["violation"] else ""))
    return out


def run(args) -> int:
    from app.core.errors import UserError
    from app.core.throw.arm import ThrowingArm
    from app.core.throw.config import load_throw_config
    from app.core.throw.simulation import simulate_full

    cfg = load_throw_config(args.config) if args.config else None
    if args.degree < 2 or args.degree > 12:
        raise UserError("--degree must be between 2 and 12")
    arm = ThrowingArm(args.robot, cfg.model if cfg else None)
    if args.thesis:
        return _thesis(args, arm)
    if args.robust and not args.optimize:
        raise UserError("--robust needs --optimize")
    if args.optimize and args.robust:
        return _optimize_robust(args, arm, cfg)
    if args.optimize:
        return _optimize(args, arm)
    if cfg is None:
        raise UserError("give a throw file or a shipped throw (throw1, throw2, throw3), or --optimize, or --thesis")
    if (args.monte_carlo is not None or args.catch) and not args.closed_loop:
        raise UserError("--monte-carlo and --catch need --closed-loop")
    throw = arm.solve(cfg.spec)
    feas = throw.check()
    sims = [simulate_full(throw, c) for c in ("feedforward", "computed_torque")] if args.verify else []
    if args.closed_loop:
        closed = _closed_loop(args, throw)
        if not args.json:
            return 0
    if args.json:
        out = throw_json(arm, throw, feas)
        if sims:
            out["verification"] = [verification_json(s) for s in sims]
        if args.closed_loop:
            out["closed_loop"] = closed
        json.dump(out, sys.stdout)
        sys.stdout.write("\n")
        return 0
    _print_throw(cfg.title, arm, throw, feas, cfg.thesis, sims)
    return 0
