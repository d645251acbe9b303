import copy

import pytest

#: A small valid scene (SI numbers) that tests modify to provoke one problem at a time.
BASE_SCENE = {
    "engine": {"name": "twin", "speed": "3000 rpm", "rotation": "clockwise"},
    "geometry": {"crank_radius": "40 mm", "rod_length": "140 mm", "pin_offset": "0.5 mm"},
    "piston": {"mass": "0.45 kg"},
    "rod": {"mass": "0.5 kg", "cg_from_big_end": "40 mm", "inertia": "0.0012 kg m^2"},
    "cylinder": [
        {"throw": "0 deg", "axial_position": "45 mm"},
        {"throw": "180 deg", "axial_position": "-45 mm"},
    ],
}


@pytest.fixture
def base_scene():
    return copy.deepcopy(BASE_SCENE)
