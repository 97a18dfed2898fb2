"""``python -m nlobs``: the command line, the same as the ``nlobs`` script."""

from nlobs.cli import app

if __name__ == "__main__":
    app(prog_name="nlobs")
