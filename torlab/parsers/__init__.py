"""Instrument parsers: one module per instrument, ``read_*(path_or_buffer) -> (DataFrame, metadata)``.

Every parser reports bad input as one :class:`~torlab.errors.TorlabInputError`
naming the file and line, and returns SI columns whose names carry the unit.
"""
