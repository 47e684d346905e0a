"""FMI units of the FMUs' variables: mkctl's unit strings as FMI unit names, and the ``<UnitDefinitions>``
element of a modelDescription.xml. Used by the pythonfmu build (:mod:`mkctl.fmu.build`) and the native one
(:mod:`mkctl.native.fmu`), so that both FMUs declare the same units."""
from __future__ import annotations

from xml.etree import ElementTree as ET

from ..errors import MkctlError

#: FMI unit names for the unit strings of mkctl that are not valid FMI names as they are.
FMI_UNIT_NAMES = {"N s/m": "N.s/m", "m/s^2": "m/s2"}
#: SI base-unit exponents of every FMI unit the FMUs use.
FMI_BASE_UNITS = {
    "m": {"m": 1}, "s": {"s": 1}, "kg": {"kg": 1}, "rad": {"rad": 1}, "1": {},
    "N": {"kg": 1, "m": 1, "s": -2}, "Pa": {"kg": 1, "m": -1, "s": -2}, "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2}, "N.s/m": {"kg": 1, "s": -1}, "1/s": {"s": -1}, "1/s2": {"s": -2},
    "Pa/s": {"kg": 1, "m": -1, "s": -3},
    # the air's (model-spec 4d): the air's temperature, a sonic conductance C [m^3/(s Pa)], a mass flow
    "K": {"K": 1}, "m3/(s.Pa)": {"kg": -1, "m": 4, "s": 1}, "kg/s": {"kg": 1, "s": -1},
}


#: SI base-unit exponents of the unit symbols a unit string may combine (an effect's own unit, "N/Pa").
_SYMBOLS = {"m": {"m": 1}, "s": {"s": 1}, "kg": {"kg": 1}, "rad": {"rad": 1}, "N": {"kg": 1, "m": 1, "s": -2},
            "Pa": {"kg": 1, "m": -1, "s": -2}}


class UnitError(MkctlError, ValueError):
    """A unit an FMU cannot declare (no base-unit definition)."""


def fmi_unit(unit: str) -> str:
    """The FMI name of one of mkctl's unit strings (``"N s/m"`` -> ``"N.s/m"``, ``"m/s^2"`` -> ``"m/s2"``)."""
    return FMI_UNIT_NAMES.get(unit, unit.replace(" ", ".").replace("^", ""))


def base_units(unit: str) -> dict | None:
    """SI base-unit exponents of an FMI unit name: the table's, or a product/quotient of N, Pa, m, s, kg, rad
    with integer powers ("N/Pa" -> m^2); None when it is neither."""
    if unit in FMI_BASE_UNITS:
        return FMI_BASE_UNITS[unit]
    import re
    total: dict = {}
    numerator, _, denominator = unit.partition("/")
    for sign, part in ((1, numerator), (-1, denominator)):
        for token in filter(None, part.split(".")):
            match = re.fullmatch(r"([A-Za-z]+)(-?\d*)", token)
            if not match or match.group(1) not in _SYMBOLS:
                return None
            power = sign * int(match.group(2) or 1)
            for base, exponent in _SYMBOLS[match.group(1)].items():
                total[base] = total.get(base, 0) + power * exponent
    return {k: v for k, v in total.items() if v}


def unit_definitions(units) -> ET.Element:
    """``<UnitDefinitions>`` for the FMI unit names ``units`` (sorted, each once), with their base units.

    Raises :class:`UnitError` (a ValueError) naming the units that have no base-unit definition in
    :data:`FMI_BASE_UNITS`.
    """
    used = sorted(set(units))
    unknown = [u for u in used if base_units(u) is None]
    if unknown:
        raise UnitError(f"no base-unit definition for unit(s) {unknown}: an FMU's units are products and "
                        f"quotients of N, Pa, m, s, kg, rad with integer powers (e.g. 'N s/m', 'N/Pa')")
    definitions = ET.Element("UnitDefinitions")
    for unit in used:
        node = ET.SubElement(definitions, "Unit", name=unit)
        if base_units(unit):
            ET.SubElement(node, "BaseUnit", {k: str(v) for k, v in base_units(unit).items()})
    return definitions
