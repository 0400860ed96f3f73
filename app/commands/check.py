"""``python -m app check [ROBOT ...] [--states N]``: cross-check the symbolic model against
pinocchio (M, C q', g at random states, relative tolerance 1e-9). Exit code 1 on a mismatch."""
NAME = "check"
HELP = "cross-check symbolic dynamics against pinocchio"
MAX_STATES = 100_000


def add_arguments(p):
    p.add_argument("robots", nargs="*", help="robot names or files (default: every shipped robot)")
    p.add_argument("--states", type=int, default=50, help="number of random states (default 50)")
    p.add_argument("--seed", type=int, default=0)


def run(args) -> int:
    from app.core.numeric import cross_check
    from app.core.errors import UserError
    from app.core.robot import list_robot_names, load_robot

    if not 1 <= args.states <= MAX_STATES:
        raise UserError(f"--states must be from 1 to {MAX_STATES}")
    names = args.robots or list_robot_names()
    bad = 0
    for name in names:
        result = cross_check(load_robot(name), states=args.states, seed=args.seed)
        print(result.summary())
        bad += not result.ok
    return 1 if bad else 0
