"""The stored common units are pint's own answers, and using them does not load pint."""

import math
import subprocess
import sys
from pathlib import Path

from torlab._unit_table import CANDIDATES, KNOWN
from torlab.units import _normalise_unit, generate_unit_table, parse_unit_factor, to_si

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "protocols" / "scenes" / "wheel_rail_tab54.yaml"


def test_every_stored_unit_is_what_pint_gives():
    # pint computes each entry now (the table is bypassed); equal to the last bit
    fresh = generate_unit_table()
    assert set(fresh) == set(KNOWN)
    for key, value in KNOWN.items():
        assert fresh[key] == value, key
    from torlab._unit_table import KIND_DIMENSIONS, UNIT_DIMENSIONS
    from torlab.units import generate_unit_dimensions

    assert generate_unit_dimensions() == (UNIT_DIMENSIONS, KIND_DIMENSIONS)


def test_every_candidate_spelling_is_stored_and_used():
    for kind, units in CANDIDATES.items():
        for unit in units:
            assert (_normalise_unit(unit), kind) in KNOWN
            assert parse_unit_factor(unit, kind) == KNOWN[(_normalise_unit(unit), kind)]


def test_known_conversions():
    # hand values, independent of pint and of the table
    for text, kind, si in (("20 kN", "force", 20e3), ("3.7 mm", "length", 3.7e-3),
                           ("4 uL", "volume", 4e-9), ("4 µl", "volume", 4e-9),
                           ("300 K", "temperature", 26.85), ("2 degC", "temperature_difference", 2),
                           ("1 mPa*s", "viscosity", 1e-3), ("21500 mm^-2", "areal_density", 2.15e10),
                           ("15 1/GPa", "inverse_pressure", 15e-9), ("10 m/s", "velocity", 10.0)):
        assert math.isclose(to_si(text, kind), si, rel_tol=1e-14), text


def test_an_ordinary_scene_loads_without_pint():
    code = ("import sys; from torlab.scene import load_scene; "
            f"load_scene({str(SCENE)!r}); print('pint' in sys.modules)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert res.stdout.strip() == "False"


def test_a_unit_outside_the_table_still_goes_through_pint():
    assert abs(to_si("1 inch", "length") - 0.0254) < 1e-15


def test_band_note_without_covariance_is_the_band_modules():
    # predict_traction skips loading the band code for a scene without a covariance; its
    # note must be the one the band module gives
    from torlab.model.bands import scene_uncertainty
    from torlab.model.predict import NO_COVARIANCE
    from torlab.scene import load_scene

    sc = load_scene(SCENE)
    assert scene_uncertainty(sc).notes == [NO_COVARIANCE]


def test_a_common_unit_of_the_wrong_kind_gets_pints_message_without_pint():
    from torlab._unit_table import UNIT_DIMENSIONS
    from torlab.errors import TorlabInputError
    from torlab.units import KINDS, _pint_factor, _wrong_kind

    checked = 0
    for u in UNIT_DIMENSIONS:
        for kind in KINDS:
            fast = _wrong_kind(u, u, kind)
            if fast is None:
                continue
            try:
                _pint_factor(u, u, kind)
            except TorlabInputError as e:
                assert e.message == fast, (u, kind)
                checked += 1
            else:
                raise AssertionError(f"pint accepts {u!r} as {kind}; the table says no")
    assert checked > 1000
