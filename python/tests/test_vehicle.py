"""Vehicle: Table I, files, keyword construction, validation with the CLI's messages."""

import math
import pickle

import pytest

import trailer_sway as ts
from conftest import CONFIGS, cli_error


def test_table1_is_the_shipped_vehicle_file(table1):
    # reference: configs/vehicle.toml (Table I) read by the CLI's reader
    assert ts.Vehicle.from_toml(CONFIGS / "vehicle.toml") == table1
    assert table1.trailer_mass == 985.0 and table1.tractor_front_axle == 5.15
    assert table1.gravity == 9.81


def test_fields_roundtrip(table1, tmp_path):
    d = table1.to_dict()
    assert list(d) == ts.Vehicle.fields() and len(d) == 15
    assert ts.Vehicle(**d) == table1
    # the vehicle file written by to_toml reads back bit for bit
    f = tmp_path / "v.toml"
    f.write_text(table1.to_toml())
    assert ts.Vehicle.from_toml(f) == table1
    assert pickle.loads(pickle.dumps(table1)) == table1
    heavy = table1.replace(trailer_mass=1400.0)
    assert heavy.trailer_mass == 1400.0 and heavy.tractor_mass == table1.tractor_mass
    assert table1.trailer_mass == 985.0  # unchanged
    # gravity has a default, as in a vehicle file
    d.pop("gravity")
    assert ts.Vehicle(**d).gravity == 9.81


def _write_vehicle(tmp_path, **changes):
    v = ts.Vehicle.table1().to_dict()
    bad = (CONFIGS / "vehicle.toml").read_text()
    f = tmp_path / "bad_vehicle.toml"
    for k, x in changes.items():
        section, key = k.split(".")
        old = f"{key} = {v[section + '_' + key]!r}"
        lines = bad.splitlines()
        # replace the key inside its section
        in_section = False
        for i, line in enumerate(lines):
            if line.startswith("["):
                in_section = line.strip().startswith(f"[{section}]")
            elif in_section and line.split("=")[0].strip() == key:
                lines[i] = f"{key} = {x}"
        bad = "\n".join(lines) + "\n"
    f.write_text(bad)
    return f


@pytest.mark.parametrize(
    "key,value",
    [("trailer.mass", "-985.0"), ("tractor.rear_axle", "6.0"), ("friction.mu_dynamic", "0.95"), ("trailer.cog", "nan")],
)
def test_invalid_vehicle_file_raises_the_cli_message(tmp_path, key, value):
    # reference: the message `cargo xtask linear --vehicle FILE --check` prints
    f = _write_vehicle(tmp_path, **{key: value})
    expected = cli_error("linear", "--vehicle", f, "--check")
    with pytest.raises(ValueError) as e:
        ts.Vehicle.from_toml(f)
    assert str(e.value) == expected
    assert f"`{key}`" in expected


def test_invalid_fields_name_the_key(table1):
    with pytest.raises(ValueError, match=r"`trailer.mass`: -1 is invalid: expected a positive finite number"):
        table1.replace(trailer_mass=-1.0)
    with pytest.raises(ValueError, match=r"`trailer.cog`: NaN is invalid"):
        table1.replace(trailer_cog=math.nan)
    with pytest.raises(ValueError, match=r"`tractor.rear_axle`: 6 is invalid: expected 0 < c < f"):
        table1.replace(tractor_rear_axle=6.0)
    with pytest.raises(TypeError, match="unknown field `trailer_weight`"):
        table1.replace(trailer_weight=1.0)
    with pytest.raises(TypeError, match="expected a number"):
        table1.replace(trailer_mass="heavy")
    with pytest.raises(TypeError, match="missing field"):
        ts.Vehicle(trailer_mass=900.0)
    with pytest.raises(OSError, match="cannot read"):
        ts.Vehicle.from_toml("/nonexistent/vehicle.toml")
