"""The fitness of a swim (thesis eq. 3.14): far for little bending and wake energy, each term made
dimensionless by a reference creature's."""

from dataclasses import dataclass


@dataclass(frozen=True)
class FitnessScales:
    """What makes each term of eq. 3.14 dimensionless: a reference creature's path, bending
    energy and energy loss (see ``reference_scales``)."""

    path: float
    bending: float
    energy: float


def fitness(path_m, bending_energy, energy_loss, config, scales: FitnessScales | None = None):
    """Eq. 3.14, w_d D - w_b E^b - w_e E^l. With ``scales`` each term is over the reference's
    (the thesis divides E^l by the largest seen so far, which makes the fitness of one creature
    change with the others; a fixed reference keeps it one objective for every method).
    Without, D is in bell diameters and the energies are left out."""
    w_d, w_b, w_e = config.weights
    if scales is None:
        return w_d * path_m / config.bell.diameter
    return w_d * path_m / scales.path - w_b * bending_energy / scales.bending - w_e * energy_loss / scales.energy
