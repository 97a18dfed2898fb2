"""The closed sets of values the commands' options take, as enums: ``--help`` and shell completion list them.

The values are written here (importing the modules that define them would slow every command's start);
``tests/test_cli_choices.py`` checks that each set equals the one the library accepts. A command turns a member
back into its value with :func:`value` before calling the library.
"""

from __future__ import annotations

from enum import Enum
from typing import Any


def _choices(name: str, values: tuple[str, ...]) -> Any:
    """A ``str`` enum whose members' values are ``values`` (names: the values with ``-`` as ``_``)."""
    return Enum(name, [(v.replace("-", "_"), v) for v in values], type=str, module=__name__)


Backend = _choices("Backend", ("python", "c"))
Paper = _choices("Paper", ("grip2013", "dallamora2000", "robenack2008", "khajenejad-yong"))
Demo = _choices("Demo", ("gnss-ins",))
DemoGains = _choices("DemoGains", ("noise-optimal", "paper", "designed"))
Schedule = _choices("Schedule", ("scheduled", "constant"))
StudyGains = _choices("StudyGains", ("scheduled", "noise-optimal", "paper"))
OnOff = _choices("OnOff", ("on", "off"))
DriftMethod = _choices("DriftMethod", ("vandermonde", "sdp"))
CascadeMethod = _choices("CascadeMethod", ("lmi", "placement", "h2"))
ExportMethod = _choices("ExportMethod", ("vandermonde", "sdp", "lmi", "placement", "h2"))
Placement = _choices("Placement", ("powers", "multiple"))
Lang = _choices("Lang", ("c",))
Exported = _choices("Exported", ("drift", "pinv", "luenberger", "cascade", "ekf", "ukf", "setvalued", "gnss-ins"))


def value(member: Any) -> Any:
    """The plain value of an option: an enum member's ``value``, anything else (``None``, a string) itself."""
    return member.value if isinstance(member, Enum) else member
