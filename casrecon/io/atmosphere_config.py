"""The ``[atmosphere]`` table of a 6-DOF problem: the sounding, its stated uncertainty and the
fit's profile-error model."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from casrecon.io.toml_fields import Fields


@dataclass(frozen=True)
class AtmosphereConfig:
    """Balloon sounding file, its stated uncertainty (3-sigma, as the EES paper gives it) and the
    fit's model of the profile error (1-sigma, Gauss-Markov in altitude; see
    :mod:`casrecon.estimation.error_models.profile`).

    Profile-error defaults: a GPS-tracked radiosonde measures wind to about 0.15 m/s and
    temperature and pressure to about 0.1 % in density, but the balloon flies tens of minutes
    before or after the drop and drifts kilometres downwind, where boundary-layer wind differs by
    0.5 to 1 m/s over a few hundred metres of height; a sounding without dewpoints (its density
    that of dry air, p / (R T)) leaves out humidity's 0.2 to 1 %. Hence 0.5 m/s per wind
    component and 0.5 % in density, over a 300 m correlation length. A sounding that is the air
    flown through (synthetic data) sets both sigmas to 0.

    ``profile_sigma_from_data``: after the fit, estimate the profile sigmas and their correlation
    length (1/3 to 10 times ``profile_length_m``) from the data (type-II maximum likelihood,
    :mod:`casrecon.estimation.error_models.profile_sigma`) and, where they differ from the
    configured ones by more than 25 %, fit again with them (without the profile model when the
    data show none), so that neither the bands nor the aero sigmas rest on a guessed size. Per-drop
    fits without disturbance states and with the MAP method only; each refit costs a fit, and the
    estimate is made again on it (at most three refits).

    ``sounding_shift_sigma_m``: 1-sigma of the prior on the sounding's altitude shift (the
    estimated ``sounding_shift_m``: every level, and the profile corrections, that much higher in
    the drop's frame than the file says); 0 (the default): held at zero. Held, a fit takes its
    absolute altitude from the sounding's wind shape, to centimetres, even where the GPS heights
    say metres (its published altitude bands are floored by what the GPS heights say); estimated
    (20 m is a radiosonde's height error and a profile's rise and sink between balloon and drop),
    the shift itself absorbs air the profile grid cannot place and the alpha_T
    and dynamic-pressure bands suffer (docs/design/error-models.md: The sounding's altitude shift).

    ``humidity``: the density of moist air from the sounding's dewpoints where it has them (the
    default); false: dry air, p / (R_d T), as if the sounding had no dewpoints (to compare with a
    tool or an earlier result that ignores humidity, or when the sounding's hygrometer is not
    trusted). A sounding with a density column is used as given either way."""

    sounding: Path
    launch: int = 0
    wind_3sigma_mps: float = 1.0
    density_3sigma: float = 0.01
    profile_wind_sigma_mps: float = 0.5
    profile_density_sigma: float = 0.005
    profile_length_m: float = 300.0
    profile_step_m: float = 10.0
    profile_sigma_from_data: bool = True
    sounding_shift_sigma_m: float = 0.0
    humidity: bool = True


def parse_atmosphere(t: Fields) -> AtmosphereConfig:
    """The ``[atmosphere]`` table of a 6-DOF problem, validated (located InputError on a bad key)."""
    d = AtmosphereConfig  # the defaults, written once: on the record's fields
    cfg = AtmosphereConfig(sounding=t.path_of("sounding", required=True), launch=t.integer("launch", d.launch, 0),
                           wind_3sigma_mps=t.number("wind_3sigma_mps", d.wind_3sigma_mps, positive=True),
                           density_3sigma=t.number("density_3sigma", d.density_3sigma, positive=True),
                           profile_wind_sigma_mps=t.number("profile_wind_sigma_mps", d.profile_wind_sigma_mps,
                                                           minimum=0.0),
                           profile_density_sigma=t.number("profile_density_sigma", d.profile_density_sigma,
                                                          minimum=0.0),
                           profile_length_m=t.number("profile_length_m", d.profile_length_m, positive=True),
                           profile_step_m=t.number("profile_step_m", d.profile_step_m, positive=True),
                           profile_sigma_from_data=t.boolean("profile_sigma_from_data", d.profile_sigma_from_data),
                           sounding_shift_sigma_m=t.number("sounding_shift_sigma_m", d.sounding_shift_sigma_m,
                                                           minimum=0.0),
                           humidity=t.boolean("humidity", d.humidity))
    if cfg.profile_step_m > cfg.profile_length_m:
        raise t.error("profile_step_m", f"expected a grid step at most the correlation length profile_length_m = "
                                        f"{cfg.profile_length_m:g} m, got {cfg.profile_step_m:g} m")
    t.reject_unknown()
    return cfg
