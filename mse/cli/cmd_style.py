"""``mse style train|adapt|synth``: HSMM stylistic motion synthesis (Tilmanne et al.).

```
mse style train --library DIR --action walk -o walk.avg
mse style train --library DIR --action walk --style sad -o walk.sad-only   # no average model
mse style adapt walk.avg --library DIR --style sad --takes 1 -o walk.sad
mse style synth walk.sad --steps 6 -o sad_walk.bvh      # or --duration 5
```
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import Any

from mse.cli.common import add_quiet, print_error
from mse.diagnostics import Diagnostic, MseError, Span, argument_error
from mse.fileio import refuse_inputs
from mse.limits import MAX_MOTION_SECONDS, MAX_STEPS


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "style",
        help="HSMM stylistic motion: train an average model, adapt it, synthesize",
        description="Stylistic motion synthesis with hidden semi-Markov models: an average "
        "model over every style of a motion library, adapted to one style from a few takes "
        "(CMLLR + MAP), then maximum-likelihood parameter generation with global variance.",
    )
    commands = parser.add_subparsers(dest="style_command", metavar="STEP")

    train = commands.add_parser(
        "train",
        help="train the average model of an action (with --style: one style's own model)",
        description="Train the average HSMM of one action over every style of a motion library "
        "(with --style: a model of that style alone, from its own takes). An unknown action or "
        "style is an error listing those the library has.",
    )
    add_quiet(train)
    train.add_argument("--library", required=True, help="motion library folder or index")
    train.add_argument("--action", required=True, help="action label, e.g. walk or bow")
    train.add_argument(
        "--style",
        help="train a model of this style on its own takes only (no average model; "
        "on Bandai walks as good as adaptation from about two steps of data)",
    )
    train.add_argument(
        "--takes", type=int, default=0, help="with --style: takes to use (default 0: all)"
    )
    train.add_argument("-o", "--output", required=True, help="model file to write")
    train.add_argument("--states", type=int, default=5, help="states per unit (default 5)")
    train.add_argument(
        "--blocks",
        choices=("joint", "stream", "full"),
        default="stream",
        help="CMLLR regression blocks (default stream: one per static/delta/delta-delta "
        "stream; joint: 3x3 per joint and stream; full)",
    )
    train.set_defaults(handler=run_train)

    adapt = commands.add_parser(
        "adapt",
        help="adapt a model to a style from a few takes",
        description="Adapt an average model (from 'mse style train') to one style of the library "
        "from a few takes of it: CMLLR, then MAP unless --no-map.",
    )
    add_quiet(adapt)
    adapt.add_argument("model", help="average model file (from 'mse style train')")
    adapt.add_argument("--library", required=True, help="motion library folder or index")
    adapt.add_argument("--style", required=True, help="target style label, e.g. sad")
    adapt.add_argument("--takes", type=int, default=1, help="takes to use (default 1; 0: all)")
    adapt.add_argument("--no-map", action="store_true", help="CMLLR only, no MAP step")
    adapt.add_argument("-o", "--output", required=True, help="adapted model file to write")
    adapt.set_defaults(handler=run_adapt)

    synth = commands.add_parser(
        "synth",
        help="synthesize a BVH clip from a model",
        description="Synthesize a BVH clip from an average or adapted model by maximum-likelihood "
        "parameter generation with global variance, for a number of steps or an exact duration.",
    )
    add_quiet(synth)
    synth.add_argument("model", help="model file (average or adapted)")
    length = synth.add_mutually_exclusive_group()
    length.add_argument(
        "--steps", type=int, help="number of steps (cyclic actions; default 2: a first and a last step)"
    )
    length.add_argument("--duration", type=float, help="exact length in seconds")
    synth.add_argument("--no-gv", action="store_true", help="no global-variance compensation")
    synth.add_argument("--seed", type=int, help="vary the state durations reproducibly")
    synth.add_argument("-o", "--output", required=True, help="BVH file to write")
    synth.set_defaults(handler=run_synth)

    parser.set_defaults(handler=lambda _args: _usage(parser))


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help(sys.stderr)
    return 2


def _fail(path: str, message: str) -> int:
    return print_error(MseError([Diagnostic("E100", message, Span(path))]))


def _positive(value: float | None, name: str) -> str | None:
    if value is not None and not value > 0:
        return f"{name} must be positive"
    return None


def _run_step(step: Callable[[], str], source: str, output: str, verb: str, product: str) -> int:
    """Run one step and print ``output: summary, time``; its failures become located errors
    (a bad input at ``source``, an unwritable ``output``)."""
    started = time.perf_counter()
    try:
        summary = step()
    except MseError as error:
        return print_error(error)
    except ValueError as error:
        return _fail(source, f"cannot {verb}: {error}")
    except OSError as error:
        return _fail(output, f"cannot write {product}: {error.strerror or error}")
    elapsed = time.perf_counter() - started
    took = f"{elapsed:.1f} s" if elapsed >= 1 else f"{1000 * elapsed:.0f} ms"
    print(f"{output}: {summary}, {took}", file=sys.stderr)
    return 0


def run_train(args: argparse.Namespace) -> int:
    from mse.motion.base.library import load_library
    from mse.motion.hsmm.api import Options
    from mse.motion.hsmm.io import save_model
    from mse.motion.hsmm.leaf import train_from_library

    if args.states < 1:
        return print_error(argument_error("--states must be at least 1"))
    if args.takes < 0:
        return print_error(argument_error("--takes must be 0 (all) or more"))
    if args.takes and args.style is None:
        return print_error(argument_error("--takes goes with --style"))
    try:  # the library's clips are inputs: -o must not name one (E105)
        load_library(args.library)
        refuse_inputs(args.output, [args.library])
    except MseError as error:
        return print_error(error)

    def step() -> str:
        options = Options(states=args.states, blocks=args.blocks)
        model = train_from_library(
            args.library, args.action, options, style=args.style, takes=args.takes or None
        )
        save_model(args.output, model)
        shape = f"{len(model.units)} unit(s) x {model.states} states"
        if args.style is not None:
            return f"{args.style} {args.action} model, {shape}, from its {model.info.get('takes')} take(s) alone"
        return f"average {args.action} model, {shape}, {model.info.get('clips')} clip(s)"

    return _run_step(step, args.library, args.output, "train", "model")


def run_adapt(args: argparse.Namespace) -> int:
    from mse.motion.base.library import load_library
    from mse.motion.hsmm.api import Options
    from mse.motion.hsmm.io import load_model, save_model
    from mse.motion.hsmm.leaf import adapt_from_library

    if args.takes < 0:
        return print_error(argument_error("--takes must be 0 (all) or more"))
    try:  # the model and the library's clips are inputs: -o must not name one (E105)
        load_library(args.library)
        refuse_inputs(args.output, [args.model, args.library])
    except MseError as error:
        return print_error(error)

    def step() -> str:
        average = load_model(args.model)
        options = Options(
            states=average.states,
            blocks=str(average.info.get("blocks", "stream")),
            use_map=not args.no_map,
        )
        model = adapt_from_library(average, args.library, args.style, args.takes or None, options)
        save_model(args.output, model)
        return f"{model.action} model adapted to {args.style!r} from {model.info.get('takes')} take(s)"

    return _run_step(step, args.library, args.output, "adapt", "model")


def run_synth(args: argparse.Namespace) -> int:
    from mse.motion.base.bvh import write_bvh
    from mse.motion.hsmm.io import load_model
    from mse.motion.hsmm.synth import synthesize

    problem = _positive(args.duration, "--duration") or _positive(args.steps, "--steps")
    if args.duration is not None and not args.duration <= MAX_MOTION_SECONDS:
        problem = f"--duration must be in (0, {MAX_MOTION_SECONDS:g}] seconds"
    if args.steps is not None and args.steps > MAX_STEPS:
        problem = f"--steps must be between 1 and {MAX_STEPS}"
    if problem:
        return print_error(argument_error(problem))
    try:
        refuse_inputs(args.output, [args.model])
    except MseError as error:
        return print_error(error)

    def step() -> str:
        model = load_model(args.model)
        motion = synthesize(
            model, steps=args.steps, duration_s=args.duration, gv=not args.no_gv, seed=args.seed
        )
        write_bvh(args.output, motion)
        return (
            f"{motion.frame_count} frames ({motion.duration:.2f} s) of {model.style} {model.action}"
        )

    return _run_step(step, args.model, args.output, "synthesize", "BVH")
