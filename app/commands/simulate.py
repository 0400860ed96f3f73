"""``python -m app simulate ROBOT --controller NAME [--gains K=V,...] [--reference SPEC] --duration T --out run.csv``

Runs a controller in closed loop on a robot (app/core/sim.py) and writes every signal as CSV (one
row per control sample: t, q, dq, ddq, tau, the reference, errors, controller internals, contact
forces). Prints a short summary, or one JSON object with ``--json``. ``--list`` prints the
controllers with their laws and gains.

Exit codes: 0 the run completed; 1 it stopped early (diverged, left the joint limits: the message
says when, and the CSV holds the samples up to then); 2 bad input.
"""
from __future__ import annotations

import json
import sys

NAME = "simulate"
HELP = "run a controller in closed loop on a robot and write the signals as CSV"


def add_arguments(p):
    p.add_argument("robot", nargs="?", help="a shipped robot's name or a path to a robot file")
    p.add_argument("--controller", "-c", help="controller name (see --list)")
    p.add_argument("--list", action="store_true", help="list the controllers, their laws and gains, and exit")
    p.add_argument("--gains", "-g", default="", metavar="K=V,...",
                   help="gains by name, e.g. Kp=100,Kd=20 (all joints) or Kp2=50 (joint 2 only)")
    p.add_argument("--reference", "-r", default="", metavar="SPEC",
                   help="'setpoint goal=..', 'cubic|quintic goal=.. T=..', 'bangbang goal=.. amax=..', "
                        "'trapezoidal goal=.. vmax=.. amax=..', 'sine amplitude=.. f=.. [center=..] [phase=..]' "
                        "(vectors comma-separated; default: hold the initial value)")
    p.add_argument("--duration", "-T", type=float, default=2.0, help="simulated time [s] (default 2)")
    p.add_argument("--rate", type=float, default=1000.0, help="control rate [Hz] (default 1000)")
    p.add_argument("--substeps", type=int, default=1, help="RK4 steps of the plant per control period (default 1)")
    p.add_argument("--q0", help="initial coordinates, comma-separated (default: the robot file's defaults, else 0)")
    p.add_argument("--dq0", help="initial velocities, comma-separated (default 0)")
    p.add_argument("--plant", default="", metavar="P=V,...",
                   help="parameters of the real robot that differ from the file (e.g. m2=7)")
    p.add_argument("--model", default="", metavar="P=V,...",
                   help="parameters of the controller's model that differ from the file (model mismatch)")
    p.add_argument("--viscous", help="extra viscous friction of the plant [N m s/rad], one value or one per joint")
    p.add_argument("--saturation", help="torque bounds, one value or one per joint, or 'limits' (the file's)")
    p.add_argument("--passive", help="comma-separated passive coordinates (default: the file's); '' for none")
    p.add_argument("--force", action="append", default=[], metavar="SPEC",
                   help="a force on a point: 'POINT F=fx,fy [M=moment] [from=t0] [to=t1] [at=x,y,z]' (POINT: a "
                        "named point or a body, with at= its local position; M: a moment on the body); repeatable")
    p.add_argument("--surface", action="append", default=[], metavar="SPEC",
                   help="a surface the point cannot cross: 'POINT normal=nx,ny [offset=o] [k=stiffness d=damping]' "
                        "(rigid without k; through the point's initial position without offset); repeatable")
    p.add_argument("--observer", metavar="KI", help="run the momentum-based collision residual with gain K_I")
    p.add_argument("--point", help="task point of Cartesian controllers (default: a surface's point, else ee)")
    p.add_argument("--backend", choices=["auto", "pinocchio", "symbolic"], default="auto",
                   help="dynamics evaluation (default auto: pinocchio where it applies)")
    p.add_argument("--out", "-o", help="CSV file to write")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")


def _contacts(args):
    from app.core.sim_input import parse_contact
    return ([parse_contact("force", text) for text in args.force]
            + [parse_contact("surface", text) for text in args.surface])


def list_controllers(out=None) -> None:
    from app.core.control import CONTROLLERS
    out = out or sys.stdout
    for name in sorted(CONTROLLERS):
        cls = CONTROLLERS[name]
        print(f"{name}: {cls.title}", file=out)
        print(f"  law: {cls.law_latex}", file=out)
        print(f"  closed loop: {cls.closed_loop}", file=out)
        print("  gains:", file=out)
        for line in cls(None).describe_gains().splitlines():
            print("  " + line, file=out)
        print(file=out)


def summary(res) -> dict:
    """Numbers that characterize a run (for the printed summary and --json)."""
    import numpy as np
    late = res.t >= res.t[-1] - 0.1 * (res.t[-1] - res.t[0]) if len(res.t) > 1 else np.ones(len(res.t), bool)
    out = dict(res.metadata())
    out.update({
        "samples": int(len(res.t)),
        "final_time_s": float(res.t[-1]),
        "final_error": [float(x) for x in res.e[-1]],
        "max_abs_error": [float(x) for x in np.max(np.abs(res.e), axis=0)],
        "max_abs_error_last_10pct": [float(x) for x in np.max(np.abs(res.e[late]), axis=0)],
        "max_abs_tau": [float(x) for x in np.max(np.abs(res.tau), axis=0)],
        "reference_coordinates": res.reference_names,
        "coordinates": res.coordinates,
        "real_time_factor": float(res.real_time_factor),
        "wall_time_s": float(res.wall_time),
    })
    return out


def options(args):
    """The SimOptions of the command line's options (a SimulationError names a bad one)."""
    from app.core.controller_base import parse_gains
    from app.core.sim import SimOptions
    from app.core.sim_input import parse_assignments, parse_numbers
    passive = None
    if args.passive is not None:
        passive = [c.strip() for c in args.passive.split(",") if c.strip()]
    saturation = args.saturation
    if saturation is not None and saturation.strip() != "limits":
        saturation = parse_numbers(saturation, "--saturation")
    observer = parse_numbers(args.observer, "--observer") if args.observer is not None else None
    return SimOptions(
        duration=args.duration, rate=args.rate, substeps=args.substeps, q0=parse_numbers(args.q0, "--q0"),
        dq0=parse_numbers(args.dq0, "--dq0"), gains=parse_gains(args.gains),
        plant_params=parse_assignments(args.plant, "--plant") or None,
        model_params=parse_assignments(args.model, "--model") or None, viscous=parse_numbers(args.viscous, "--viscous"),
        saturation=saturation.strip() if isinstance(saturation, str) else saturation, passive=passive,
        contacts=_contacts(args), observer=observer, point=args.point, backend=args.backend)


def run(args) -> int:
    from app.core.errors import UserError
    from app.core.sim import simulate

    if args.list:
        list_controllers()
        return 0
    if not args.robot:
        raise UserError("give a robot (a shipped name or a robot file), or --list for the controllers")
    if not args.controller:
        raise UserError("give a controller with --controller NAME (--list shows them)")
    res = simulate(args.robot, args.controller, reference=args.reference or None, options=options(args))
    if args.out:
        try:
            res.to_csv(args.out)
        except OSError as exc:
            raise UserError(f"--out: cannot write {args.out}: {exc.strerror}") from None
    info = summary(res)
    if args.json:
        json.dump(info, sys.stdout)
        sys.stdout.write("\n")
    else:
        status = "completed" if res.completed else f"STOPPED: {res.message}"
        print(f"{res.robot} / {res.controller} ({res.title}): {status}")
        print(f"  reference: {res.reference}")
        print(f"  gains: {info['gains']}")
        fmt = lambda xs: ", ".join(f"{n}={x:.3g}" for n, x in zip(res.reference_names, xs))
        print(f"  error at t = {res.t[-1]:.3f} s: {fmt(info['final_error'])}")
        print(f"  max |error| over the last 10%: {fmt(info['max_abs_error_last_10pct'])}")
        print("  max |tau|: " + ", ".join(f"{c}={x:.3g}" for c, x in zip(res.coordinates, info["max_abs_tau"])))
        print(f"  {len(res.t)} samples at {res.rate:g} Hz, {res.real_time_factor:.0f}x real time"
              + (f", written to {args.out}" if args.out else ""))
    if not res.completed:
        print(f"error: {res.message}", file=sys.stderr)
        return 1
    return 0
