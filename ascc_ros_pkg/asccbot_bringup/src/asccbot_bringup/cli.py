"""``asccbot_urdf [name:=value ...]``: print the ASCCbot's URDF (``description.py``).

The names are ``DescriptionParams``'s, written as in roslaunch (``layout:=webcam``,
``robot_model:=create_2``, ``layer_heights_m:=[0.1,0.17,0.24,0.48]``); a value is read as
YAML, an empty value means the default. A launch file loads the output with
``<param name="robot_description" command="...asccbot_urdf ..."/>``. A bad name or value
ends with exit code 2 and one line naming it.
"""
import sys
from typing import List, Optional

import yaml

from ascc_common.params import ParamError, from_params, parameters

from .description import DescriptionParams, urdf


def parse(argv: List[str]) -> DescriptionParams:
    """The parameters named in ``argv`` (``name:=value``) over the defaults."""
    known = {p.name for p in parameters(DescriptionParams)}
    given = {}
    for arg in argv:
        name, sep, value = arg.partition(":=")
        if not sep or name not in known:
            raise ParamError("asccbot_urdf: %r is not name:=value with a name of %s"
                             % (arg, ", ".join(sorted(known))))
        if value.strip():
            given[name] = value if name == "frame_prefix" else yaml.safe_load(value)
    return from_params(DescriptionParams, lambda name, default: given.get(name, default))


def main(argv: Optional[List[str]] = None) -> int:
    try:
        p = parse(sys.argv[1:] if argv is None else argv)
    except ParamError as err:
        print(err, file=sys.stderr)
        return 2
    sys.stdout.write(urdf(p))
    return 0
