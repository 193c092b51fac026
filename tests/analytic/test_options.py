"""The analysis options as one object (issue 37): checked once, in the constructor, with the
command line's one-line messages; its plain-data form is summary.json's ``options`` and
rebuilds the run."""

from __future__ import annotations

import dataclasses
import json

import pytest

from dampfit import _options
from dampfit._options import AnalysisOptions, SamplerSettings
from dampfit.errors import InputError


def test_defaults_are_the_documented_ones():
    o = AnalysisOptions()
    assert o.sampler == SamplerSettings(seed=0, max_steps=20000, min_ess=1000.0, progress=False)
    assert o.resolved().max_modes == 4 and o.resolved(campaign=True).max_modes == 1
    assert o.max_modes is None  # resolving does not change the object given


def test_options_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        AnalysisOptions().model = "viscous"
    with pytest.raises(dataclasses.FrozenInstanceError):
        SamplerSettings().seed = 3


@pytest.mark.parametrize("kw, message", [
    (dict(model="linear"), "argument --model: unknown damping model 'linear'; choose one of auto"),
    (dict(amplitude=0.0), "argument --amplitude: must be a positive displacement amplitude in "
                          "metres, got 0"),
    (dict(max_modes=9), "argument --max-modes: must be an integer from 1 to 8, got 9"),
    (dict(window=(5.0, 1.0)), "argument --window: END must come after its start, got 5 1"),
    (dict(band=[(1.0, 2.0), (3.0, 2.0)]), "argument --band: the pass band needs LO < HI, got 3 2"),
    (dict(band=(0.0, 3.0)), "argument --band: must be a positive frequency [Hz], got 0"),
    (dict(mode_of_mass=5, max_modes=2), "argument --mode-of-mass: mode 5 is beyond --max-modes 2"),
    (dict(axis=" "), "argument --axis: must be x, y, z, a column name or auto, got ' '"),
])
def test_each_bad_option_is_one_line_naming_it(kw, message):
    with pytest.raises(InputError) as exc:
        AnalysisOptions(**kw)
    assert str(exc.value).startswith(message) and "\n" not in str(exc.value)


@pytest.mark.parametrize("kw, message", [
    (dict(seed=-1), "argument --seed: must be an integer from 0 to 4294967295, got -1"),
    (dict(seed=1.5), "argument --seed: not an integer: '1.5'"),
    (dict(max_steps=0), "argument --max-steps: must be an integer from 1 to 1000000, got 0"),
    (dict(min_ess=float("nan")), "argument --min-ess: must be a finite number above 0, got nan"),
    (dict(min_ess="many"), "argument --min-ess: not a number: 'many'"),
])
def test_each_bad_sampler_setting_is_one_line_naming_it(kw, message):
    with pytest.raises(InputError, match="^" + message.replace("(", r"\(").replace("+", r"\+")):
        SamplerSettings(**kw)


def test_summary_form_keeps_values_as_given_and_rebuilds_the_run():
    o = AnalysisOptions(window=(1, 5.0), band=(0.5, 3.0), model="viscous", max_modes=2,
                        sampler=SamplerSettings(seed=7, max_steps=500, min_ess=400))
    d = o.to_dict(reading={"time_unit": "ms"})
    assert json.dumps(d) == json.dumps(
        {"axis": "auto", "window": [1, 5.0], "band": [0.5, 3.0], "max_steps": 500,
         "min_ess": 400, "model": "viscous", "amplitude": None, "max_modes": 2,
         "mode_of_mass": None, "time_unit": "ms"})
    assert AnalysisOptions.from_dict(d, seed=7) == o


def test_campaign_form_has_max_modes_last_and_only_above_one():
    per_test = AnalysisOptions(window=[(1.0, 5.0), None])
    assert per_test.to_dict(campaign=True, reading={"rate": None}) == {
        "axis": "auto", "window": [[1.0, 5.0], None], "band": None, "max_steps": 20000,
        "min_ess": 1000.0, "rate": None}
    assert list(AnalysisOptions(max_modes=3).to_dict(campaign=True, reading={"rate": None}))[-2:] \
        == ["rate", "max_modes"]


def test_keywords_or_an_options_object_not_both():
    o = AnalysisOptions.of(seed=3, model="viscous")
    assert o.sampler.seed == 3 and o.model == "viscous"
    assert AnalysisOptions.of(o) is o
    with pytest.raises(InputError, match="not both"):
        AnalysisOptions.of(o, seed=4)


def test_a_registered_law_is_a_valid_model(monkeypatch):
    monkeypatch.setattr(_options, "_models", lambda: ("auto", "viscous", "half-power"))
    assert AnalysisOptions(model="half-power").model == "half-power"
