"""Figures and reports: what users put in papers.

Figures are made with matplotlib on the non-interactive Agg backend, imported
lazily (:func:`torlab.reports.plotting.pyplot`).  Every axis carries a label
with its unit.
"""


def _matplotlib_config_dir() -> None:
    """Give matplotlib a writable configuration folder before it is imported.

    matplotlib keeps its font cache in ``$XDG_CONFIG_HOME/matplotlib`` and
    ``$XDG_CACHE_HOME/matplotlib`` (``~/.config``, ``~/.cache``).  Where those cannot be
    made or written (a read-only or missing home folder), it falls back to a new
    temporary folder and prints two raw lines about it on every run; where one is a
    relative path (which the XDG specification says to ignore), it makes that folder
    under whatever folder torlab runs in.  In both cases torlab sets
    ``MPLCONFIGDIR`` instead to ``torlab-matplotlib-<uid>`` in the temporary folder
    (made with mode 0700 and used only while it is this user's own folder, not a link;
    otherwise a new private one), so the output stays one line per problem and the font
    cache is kept between runs.  A set ``MPLCONFIGDIR`` is left alone.
    """
    import os
    import stat
    import sys
    import tempfile

    if os.environ.get("MPLCONFIGDIR") or "matplotlib" in sys.modules:
        return
    home = os.path.expanduser("~")
    for env, default in (("XDG_CONFIG_HOME", ".config"), ("XDG_CACHE_HOME", ".cache")):
        base = os.environ.get(env) or os.path.join(home, default)
        if not os.path.isabs(base):  # never a folder under the working folder
            break
        d = os.path.join(base, "matplotlib")
        try:
            os.makedirs(d, exist_ok=True)
        except OSError:
            break
        if not (os.path.isdir(d) and os.access(d, os.W_OK)):
            break
    else:
        return
    uid = os.geteuid() if hasattr(os, "geteuid") else 0
    d = os.path.join(tempfile.gettempdir(), f"torlab-matplotlib-{uid}")
    try:
        os.mkdir(d, 0o700)
    except FileExistsError:
        pass
    except OSError:
        d = ""
    if d:
        try:
            st = os.lstat(d)
            mine = stat.S_ISDIR(st.st_mode) and st.st_uid == uid and not st.st_mode & 0o077
        except OSError:
            mine = False
        if not mine:
            d = tempfile.mkdtemp(prefix="torlab-matplotlib-")
    else:
        d = tempfile.mkdtemp(prefix="torlab-matplotlib-")
    os.environ["MPLCONFIGDIR"] = d


_matplotlib_config_dir()
