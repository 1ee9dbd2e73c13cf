"""pint's answers for the common units (generated; ``tests/test_units_table.py`` checks
every entry against pint).

:func:`torlab.units.parse_unit_factor` looks a normalised unit up here before it
loads pint, so a command that reads an ordinary scene or protocol does not pay
pint's start-up.  Regenerate with ``python -m torlab._unit_table`` after changing
:data:`CANDIDATES` or the unit normalisation.
"""

from __future__ import annotations

#: kind -> the unit spellings stored (as users write them; normalised for the key)
CANDIDATES: dict[str, list[str]] = {
    'dimensionless': ['%', 'percent', '1'],
    'length': ['m', 'cm', 'mm', 'um', 'µm', 'nm', 'km'],
    'area': ['m^2', 'cm^2', 'mm^2', 'um^2'],
    'volume': ['m^3', 'mm^3', 'cm^3', 'L', 'l', 'mL', 'ml', 'uL', 'ul', 'µL', 'µl', 'nL', 'nl'],
    'mass': ['kg', 'g', 'mg', 'ug', 'µg'],
    'time': ['s', 'ms', 'us', 'min', 'h'],
    'force': ['N', 'kN', 'mN', 'MN'],
    'torque': ['N*m', 'N m', 'mN*m', 'kN*m'],
    'pressure': ['Pa', 'kPa', 'MPa', 'GPa', 'bar', 'N/m^2', 'N/mm^2'],
    'inverse_pressure': ['1/Pa', '1/kPa', '1/MPa', '1/GPa', 'Pa^-1', 'MPa^-1', 'GPa^-1', '1/bar'],
    'velocity': ['m/s', 'mm/s', 'cm/s', 'km/h', 'm/min'],
    'angle': ['rad', 'mrad', 'deg', '°'],
    'viscosity': ['Pa*s', 'mPa*s', 'Pa s', 'mPa s', 'cP', 'P'],
    'density': ['kg/m^3', 'g/cm^3', 'g/mL', 'kg/L'],
    'areal_density': ['1/m^2', 'm^-2', '1/mm^2', 'mm^-2', '1/um^2', 'um^-2'],
    'mass_per_area': ['kg/m^2', 'g/m^2', 'mg/m^2', 'mg/mm^2'],
    'compliance': ['m/Pa', 'um/MPa', 'mm/GPa', 'um/GPa', 'nm/MPa'],
    'temperature': ['degC', '°C', 'K', 'degF', 'celsius'],
    'temperature_difference': ['K', 'degC', '°C', 'delta_degC', 'mK'],
    'inverse_temperature': ['1/K', 'K^-1', '1/degC', '1/delta_degC'],
    'conductivity': ['W/(m*K)', 'W/m/K', 'W/(m K)'],
    'heat_capacity': ['J/(kg*K)', 'J/kg/K', 'J/(kg K)', 'kJ/(kg*K)'],
    'frequency': ['Hz', 'kHz', '1/s'],
    'inverse_length': ['1/m', 'm^-1', '1/mm', 'mm^-1'],
}

#: (normalised unit, kind) -> (scale, offset) as pint gives them
KNOWN: dict[tuple[str, str], tuple[float, float]] = {
    ('percent', 'dimensionless'): (0.01, 0.0),
    ('1', 'dimensionless'): (1.0, 0.0),
    ('m', 'length'): (1.0, 0.0),
    ('cm', 'length'): (0.01, 0.0),
    ('mm', 'length'): (0.001, 0.0),
    ('um', 'length'): (1e-06, 0.0),
    ('nm', 'length'): (1e-09, 0.0),
    ('km', 'length'): (1000.0, 0.0),
    ('m**2', 'area'): (1.0, 0.0),
    ('cm**2', 'area'): (0.0001, 0.0),
    ('mm**2', 'area'): (1e-06, 0.0),
    ('um**2', 'area'): (1e-12, 0.0),
    ('m**3', 'volume'): (1.0, 0.0),
    ('mm**3', 'volume'): (1e-09, 0.0),
    ('cm**3', 'volume'): (1.0000000000000002e-06, 0.0),
    ('L', 'volume'): (0.0010000000000000002, 0.0),
    ('l', 'volume'): (0.0010000000000000002, 0.0),
    ('mL', 'volume'): (1.0000000000000002e-06, 0.0),
    ('ml', 'volume'): (1.0000000000000002e-06, 0.0),
    ('uL', 'volume'): (1.0000000000000003e-09, 0.0),
    ('ul', 'volume'): (1.0000000000000003e-09, 0.0),
    ('nL', 'volume'): (1.0000000000000004e-12, 0.0),
    ('nl', 'volume'): (1.0000000000000004e-12, 0.0),
    ('kg', 'mass'): (1.0, 0.0),
    ('g', 'mass'): (0.001, 0.0),
    ('mg', 'mass'): (1e-06, 0.0),
    ('ug', 'mass'): (1e-09, 0.0),
    ('s', 'time'): (1.0, 0.0),
    ('ms', 'time'): (0.001, 0.0),
    ('us', 'time'): (1e-06, 0.0),
    ('min', 'time'): (60.0, 0.0),
    ('h', 'time'): (3600.0, 0.0),
    ('N', 'force'): (1.0, 0.0),
    ('kN', 'force'): (1000.0, 0.0),
    ('mN', 'force'): (0.001, 0.0),
    ('MN', 'force'): (1000000.0, 0.0),
    ('N*m', 'torque'): (1.0, 0.0),
    ('N m', 'torque'): (1.0, 0.0),
    ('mN*m', 'torque'): (0.001, 0.0),
    ('kN*m', 'torque'): (1000.0, 0.0),
    ('Pa', 'pressure'): (1.0, 0.0),
    ('kPa', 'pressure'): (1000.0, 0.0),
    ('MPa', 'pressure'): (1000000.0, 0.0),
    ('GPa', 'pressure'): (1000000000.0, 0.0),
    ('bar', 'pressure'): (100000.0, 0.0),
    ('N/m**2', 'pressure'): (1.0, 0.0),
    ('N/mm**2', 'pressure'): (1000000.0, 0.0),
    ('1/Pa', 'inverse_pressure'): (1.0, 0.0),
    ('1/kPa', 'inverse_pressure'): (0.001, 0.0),
    ('1/MPa', 'inverse_pressure'): (1e-06, 0.0),
    ('1/GPa', 'inverse_pressure'): (1e-09, 0.0),
    ('Pa**-1', 'inverse_pressure'): (1.0, 0.0),
    ('MPa**-1', 'inverse_pressure'): (1e-06, 0.0),
    ('GPa**-1', 'inverse_pressure'): (1e-09, 0.0),
    ('1/bar', 'inverse_pressure'): (1e-05, 0.0),
    ('m/s', 'velocity'): (1.0, 0.0),
    ('mm/s', 'velocity'): (0.001, 0.0),
    ('cm/s', 'velocity'): (0.01, 0.0),
    ('km/h', 'velocity'): (0.2777777777777778, 0.0),
    ('m/min', 'velocity'): (0.016666666666666666, 0.0),
    ('rad', 'angle'): (1.0, 0.0),
    ('mrad', 'angle'): (0.001, 0.0),
    ('deg', 'angle'): (0.017453292519943295, 0.0),
    ('Pa*s', 'viscosity'): (1.0, 0.0),
    ('mPa*s', 'viscosity'): (0.001, 0.0),
    ('Pa s', 'viscosity'): (1.0, 0.0),
    ('mPa s', 'viscosity'): (0.001, 0.0),
    ('cP', 'viscosity'): (0.001, 0.0),
    ('P', 'viscosity'): (0.1, 0.0),
    ('kg/m**3', 'density'): (1.0, 0.0),
    ('g/cm**3', 'density'): (999.9999999999999, 0.0),
    ('g/mL', 'density'): (999.9999999999999, 0.0),
    ('kg/L', 'density'): (999.9999999999999, 0.0),
    ('1/m**2', 'areal_density'): (1.0, 0.0),
    ('m**-2', 'areal_density'): (1.0, 0.0),
    ('1/mm**2', 'areal_density'): (1000000.0, 0.0),
    ('mm**-2', 'areal_density'): (1000000.0, 0.0),
    ('1/um**2', 'areal_density'): (1000000000000.0001, 0.0),
    ('um**-2', 'areal_density'): (1000000000000.0001, 0.0),
    ('kg/m**2', 'mass_per_area'): (1.0, 0.0),
    ('g/m**2', 'mass_per_area'): (0.001, 0.0),
    ('mg/m**2', 'mass_per_area'): (1e-06, 0.0),
    ('mg/mm**2', 'mass_per_area'): (1.0, 0.0),
    ('m/Pa', 'compliance'): (1.0, 0.0),
    ('um/MPa', 'compliance'): (1e-12, 0.0),
    ('mm/GPa', 'compliance'): (1.0000000000000002e-12, 0.0),
    ('um/GPa', 'compliance'): (1e-15, 0.0),
    ('nm/MPa', 'compliance'): (1e-15, 0.0),
    ('degC', 'temperature'): (1.0, 0.0),
    ('K', 'temperature'): (1.0, -273.15),
    ('degF', 'temperature'): (0.5555555555555429, -17.777777777777743),
    ('celsius', 'temperature'): (1.0, 0.0),
    ('K', 'temperature_difference'): (1.0, 0.0),
    ('degC', 'temperature_difference'): (1.0, 0.0),
    ('delta_degC', 'temperature_difference'): (1.0, 0.0),
    ('mK', 'temperature_difference'): (0.001, 0.0),
    ('1/K', 'inverse_temperature'): (1.0, 0.0),
    ('K**-1', 'inverse_temperature'): (1.0, 0.0),
    ('1/degC', 'inverse_temperature'): (1.0, 0.0),
    ('1/delta_degC', 'inverse_temperature'): (1.0, 0.0),
    ('W/(m*K)', 'conductivity'): (1.0, 0.0),
    ('W/m/K', 'conductivity'): (1.0, 0.0),
    ('W/(m K)', 'conductivity'): (1.0, 0.0),
    ('J/(kg*K)', 'heat_capacity'): (1.0, 0.0),
    ('J/kg/K', 'heat_capacity'): (1.0, 0.0),
    ('J/(kg K)', 'heat_capacity'): (1.0, 0.0),
    ('kJ/(kg*K)', 'heat_capacity'): (1000.0, 0.0),
    ('Hz', 'frequency'): (1.0, 0.0),
    ('kHz', 'frequency'): (1000.0, 0.0),
    ('1/s', 'frequency'): (1.0, 0.0),
    ('1/m', 'inverse_length'): (1.0, 0.0),
    ('m**-1', 'inverse_length'): (1.0, 0.0),
    ('1/mm', 'inverse_length'): (1000.0, 0.0),
    ('mm**-1', 'inverse_length'): (1000.0, 0.0),
}


def generate() -> dict[tuple[str, str], tuple[float, float]]:
    """:data:`KNOWN` computed by pint now (what the test compares with)."""
    from torlab.units import _normalise_unit, _pint_factor

    out = {}
    for kind, units in CANDIDATES.items():
        for unit in units:
            u = _normalise_unit(unit)
            out[(u, kind)] = _pint_factor(unit, u, kind)
    return out


if __name__ == "__main__":  # pragma: no cover
    for k, v in generate().items():
        print(f"    {k!r}: {(float(v[0]), float(v[1]))!r},")
