"""The thesis model (section 5.2), one module per piece of physics.

Names follow the thesis: ``tau_c1``, ``L_mue``, ``hc``, ``F_n`` ...  Read through
``docs/model/thesis-reading.md`` where the printed equations have misprints.
"""
