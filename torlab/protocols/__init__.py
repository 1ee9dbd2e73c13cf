"""YAML test protocols: a campaign from raw logs to reports (``torlab run``)."""
