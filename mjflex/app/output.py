"""Where the commands write: output paths checked before a run, report sets replaced together.

* :func:`file_problem` / :func:`folder_problem` say (as one line, or None) why a file or a folder
  named by an option cannot be written: checked before anything runs, so that a long run never
  ends in an error about its output.
* :func:`replace_together` writes a set of files (a report's ``.md``, ``.json`` and ``.png``)
  beside their final names and renames them into place only once all of them were written: a
  run that fails while writing leaves the earlier set as it was, and an earlier set's file that
  the new set lacks is removed, so that the files of one set never come from different runs.
"""

import os
import secrets


def folder_problem(path, option) -> str | None:
    """Why ``path`` cannot be used as an output folder (created with its parents), or None."""
    if path is None or str(path) == "":
        return f"{option} needs a folder name"
    if os.path.exists(path) and not os.path.isdir(path):
        return f"{option} {os.fspath(path)!r} is a file, not a folder; give a folder (it is created if missing)"
    existing = os.path.abspath(path)  # the nearest folder or file that exists
    while not os.path.exists(existing) and os.path.dirname(existing) != existing:
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        return f"{option} {os.fspath(path)!r}: {existing!r} is a file, so the folder cannot be created there"
    if not os.access(existing, os.W_OK | os.X_OK):
        return f"{option} {os.fspath(path)!r}: folder {existing!r} is not writable"
    return None


def file_problem(path, option, suffixes=None) -> str | None:
    """Why ``path`` cannot be written as an output file (its folder must exist), or None."""
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        return f"{option} {path!r} is a folder; give a file name"
    if not os.path.isdir(folder):
        return f"{option} {path!r}: folder {folder!r} does not exist; create it or choose another"
    if not os.access(folder, os.W_OK):
        return f"{option} {path!r}: folder {folder!r} is not writable"
    if suffixes and not path.lower().endswith(suffixes):
        return f"{option} {path!r}: the file name must end in one of {', '.join(suffixes)}"
    return None


def replace_together(writers, stale=()) -> list[str]:
    """Write ``{path: write(tmp_path)}`` beside the paths, then rename all into place; returns the paths.

    Each ``write`` gets a temporary name in the same folder with the same suffix (matplotlib and
    others choose the format by it). If any write fails, the temporary files are removed and
    the existing files stay untouched. Files in ``stale`` (an earlier set's members that this
    set does not have) are removed after the renames.
    """
    written = {}
    try:
        for path, write in writers.items():
            folder, name = os.path.split(os.path.abspath(path))
            stem, suffix = os.path.splitext(name)
            # a fresh name (not mkstemp: its 0600 mode would survive the rename)
            tmp = os.path.join(folder, f".{stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp{suffix}")
            written[path] = tmp
            write(tmp)
        for path, tmp in written.items():
            os.replace(tmp, path)
    except BaseException:
        for tmp in written.values():
            if os.path.exists(tmp):
                os.remove(tmp)
        raise
    for path in stale:
        if path not in writers and os.path.exists(path):
            os.remove(path)
    return list(writers)
