"""`sagitta batch INPUTS... --out DIR ...` (also `python3 -m sagitta_batch`). Exit 0 when every file has a
recorded outcome, 1 when the engine lost files (re-run to retry them), 2 on bad arguments or inputs."""
import argparse
import sys


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="sagitta batch",
        description="Validate (or tessellate, or fit to a target error) every file of a CAD library, each in its "
        "own child process with a "
        "wall-time limit and a memory cap, on Dask.distributed; results in OUT/results.sqlite, OUT/summary.json, "
        "OUT/report.html. Re-running skips files already recorded with the same parameters.")
    parser.add_argument("inputs", nargs="+", help="files, folders (recursive: .step .stp .iges .igs .brep .brp "
                        ".bpt .rib) or @list.txt (one input a line)")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--command", choices=["validate", "tessellate"], default="validate",
                        help="sagitta subcommand run on each file (default validate: certified error)")
    parser.add_argument("--scheme", choices=["uniform", "esc"], help="tessellation scheme (sagitta's default: uniform)")
    parser.add_argument("--level", type=int, default=2, help="tessellation level (default 2; see sagitta validate --help)")
    parser.add_argument("--target-error", type=float, help="run `sagitta fit --target-error E` on each file instead "
                        "(patch models; whole CAD parts are refused: bad_input)")
    parser.add_argument("--relative", action="store_true", help="E is a fraction of the model's box diagonal")
    parser.add_argument("--peer", choices=["occt"], help="also mesh each file with OCCT and certify it "
                        "(sagitta peer occt; peer_* columns)")
    parser.add_argument("--deflection", type=float, help="OCCT's linear deflection for --peer (sagitta's default)")
    parser.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    parser.add_argument("--scheduler", help="address of an existing Dask scheduler, e.g. tcp://host:8786")
    parser.add_argument("--timeout", type=float, default=600.0, help="wall-time limit per file, seconds (600)")
    parser.add_argument("--memory", type=float, help="address-space cap per file, GiB (default: none)")
    parser.add_argument("--quiet", action="store_true", help="no progress line")
    args = parser.parse_args(argv)
    from .engine import run

    try:
        summary = run(args.inputs, args.out, scheme=args.scheme, level=args.level, command=args.command,
                      workers=args.workers, scheduler=args.scheduler, timeout=args.timeout, memory=args.memory,
                      quiet=args.quiet, target_error=args.target_error, relative=args.relative, peer=args.peer,
                      deflection=args.deflection)
    except (FileNotFoundError, ImportError, ValueError) as e:
        print(f"sagitta batch: {e}", file=sys.stderr)
        return 2
    counts = ", ".join(f"{k} {v}" for k, v in summary["outcomes"].items())
    print(f"{summary['rows']} files recorded ({counts}); {summary['processed_this_run']} processed now, "
          f"{summary['skipped_already_done']} already done; {args.out}/report.html")
    for error in summary["engine_errors"]:
        print(f"not recorded (re-run to retry): {error['path']}: {error['error']}", file=sys.stderr)
    return 1 if summary["engine_errors"] else 0


if __name__ == "__main__":
    sys.exit(main())
