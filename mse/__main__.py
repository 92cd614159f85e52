from mse.interrupts import install

install()  # before anything heavy is imported (mse/interrupts.py says why)
try:
    from mse.cli import console_main
except KeyboardInterrupt:  # Ctrl-C while the command line loads
    import sys

    print("mse: interrupted", file=sys.stderr)
    raise SystemExit(130) from None

console_main()
