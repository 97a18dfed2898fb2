"""Paper examples as functions returning frozen results (used by ``nlobs reproduce``/demos).

* :mod:`nlobs.papers.grip_example1` — Grip, Saberi & Johansen, Example 1 (Sec. 4): cascade and
  feedback observers for a Lipschitz system behind the filter 1/(s² + s + 1).
"""

from nlobs.papers.grip_example1 import Example1Result, run_example1

__all__ = ["Example1Result", "run_example1"]
