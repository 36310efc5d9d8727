"""External data (docs/guide/data.md): a catalogue map named in an integrand. The tests that need
the data folder take the ``data_dir`` fixture (skipped without ``WORKBENCH_DATA``)."""

import numpy as np
import pytest

import workbench as wb

# The top of the sphere: its truth under a map takes seconds (the certified quadrature).
PIXEL = {"type": "pixel", "pixel": [128, 80], "width": 256, "height": 256, "channel": "g"}


def test_a_catalogue_map_by_name_is_the_map_by_path(data_dir):
    by_name = wb.Integrand({**PIXEL, "env": "pisa-256"})
    by_path = wb.Integrand({**PIXEL, "env": str(data_dir / "envmaps/debevec/pisa_256x128.hdr")})
    assert by_name.truth == by_path.truth
    points = wb.Rule(n=16, seed=3).points
    assert np.array_equal(by_name(points), by_path(points))
    # The map is used: the sky gives another pixel.
    assert by_name.truth != wb.Integrand({**PIXEL, "env": "sky"}).truth


def test_an_unknown_map_name_is_a_value_error_listing_the_maps():
    with pytest.raises(ValueError, match=r"env: pisaa: cannot read: no such file, and not the name of a catalogue map \(pisa, pisa-256, grace"):
        wb.Integrand({**PIXEL, "env": "pisaa"})
