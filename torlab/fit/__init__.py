"""Parameter identification: model parameters with uncertainties from reduced data."""
