"""nlobs: design, certify and simulate nonlinear state observers."""

from __future__ import annotations

__version__ = "0.1.0"
