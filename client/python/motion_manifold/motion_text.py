"""Exponential-map text files: one frame a line, its values separated by
commas (H3.6M's 99 values a line at 50 Hz), as the server, the tool and the
command-line client read and write them. "nan" marks a missing value (for
denoising takes)."""

import os
import secrets

import numpy as np

from .motion import H36M_LAYOUT, Motion


class MotionTextError(ValueError):
    """A text file that cannot be read as a motion: the message names the file,
    the line and what was expected."""


def _rows(lines, first_line, columns, source):
    """The float32 rows of `lines` (line numbers from `first_line`)."""
    rows = []
    for offset, line in enumerate(lines):
        values = line.split(",")
        if len(values) != columns:
            raise MotionTextError(f"{source}:{first_line + offset}: {len(values)} values, expected {columns}")
        try:
            rows.append([float(v) for v in values])
        except ValueError:
            raise MotionTextError(f"{source}:{first_line + offset}: a value that is not a number "
                                  f"({line.strip()[:80]!r})") from None
    return np.asarray(rows, dtype=np.float32).reshape(len(rows), columns)


def iter_text_chunks(path, columns=99, chunk_frames=2048):
    """The file's frames in arrays of at most `chunk_frames` x `columns`, read
    as they are needed, so that a take of an hour is streamed without being
    held whole. Blank lines are skipped."""
    with open(path, encoding="utf-8") as lines:
        batch, first_line = [], 1
        for number, line in enumerate(lines, 1):
            if not line.strip():
                continue
            if not batch:
                first_line = number
            batch.append(line)
            if len(batch) == chunk_frames:
                yield _rows(batch, first_line, columns, path)
                batch = []
        if batch:
            yield _rows(batch, first_line, columns, path)


def read_text(path, frame_rate=50.0, columns=99, layout=H36M_LAYOUT):
    """The whole file as a Motion at `frame_rate` Hz (50 for the H3.6M files)."""
    chunks = list(iter_text_chunks(path, columns))
    if not chunks:
        raise MotionTextError(f"{path}: no frames")
    return Motion(np.concatenate(chunks), frame_rate, layout)


def write_file_atomically(path, text):
    """Writes `text` to a temporary file beside `path`, then renames it there,
    so that no reader sees a half-written file."""
    folder = os.path.dirname(os.path.abspath(path))
    temporary = os.path.join(folder, f".{os.path.basename(path)}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    # Created as open() would create the file (0666 less the umask), not
    # mkstemp's 0600, so that the renamed file has the usual permissions.
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def write_text(motion, path):
    """Writes the motion's values, 7 decimals, commas, one frame a line (the
    data set's layout; the rate is not in the file)."""
    lines = [",".join("%.7f" % v for v in row) for row in motion.values.astype(np.float64)]
    write_file_atomically(path, "\n".join(lines) + "\n")
