# SPDX-License-Identifier: Apache-2.0
"""relief: normal maps to displacement maps (OpenCL), from Python.

One function per operation of relief's operation table, with the command
line's modifiers as keywords (the same names and values):

    import relief
    normals = relief.read("normal.png")              # uint8 H x W x 3, as stored
    height = relief.height(normals, normal="opengl", boundary="periodic")
    offsets = relief.correct(height, scale=0.05)
    albedo = relief.bake(relief.read("albedo.png"), offsets)
    relief.write("height.exr", height)

Inputs are numpy arrays (H x W or H x W x C) of uint8 or uint16 (UNORM, as
an 8/16-bit file decodes), float16 or float32, or OpenImageIO.ImageBuf
images (read in their stored type, with their metadata: an 8-bit file's
ImageBuf decodes as the file does). Float normals are signed [-1, 1];
float data in [0, 1] (OpenImageIO's get_pixels(FLOAT) of an 8-bit file)
needs range="unsigned", and relief warns when a map looks like it.
Metadata values are numbers where they are numbers. Results are float32 H x W x C
arrays of type relief.Image, an ndarray that carries the result's metadata
(relief:method, relief:boundary, ...) in .metadata, as a file would: bake's
wrap=auto and write's integer mapping read it. Arrays have no file name:
where the command line's bake kind=auto would go by the name (a one-channel
"height.png" is refused, "rock_normal.png" is a normal map), give kind=. Keywords: strings, numbers,
True/False for on/off; device="auto"|"gpu"|"cpu"|"P:D". A value the table
refuses raises ValueError with relief's message; a failed run RuntimeError.
The GIL is released while the device works.

Every operation also takes progress= (called with the fraction done, 0 to
1; returning True cancels: relief.CancelledError) and messages= (called
with the severity, "debug", "info", "notice" or "warning", and one line of
text). Warnings also go through warnings.warn as relief.ReliefWarning, so
the warnings filters apply (an "error" filter stops the operation and
raises). Ctrl-C stops a running operation at its next kernel and raises
KeyboardInterrupt; so does any exception raised in a callback.
"""
import json as _json
import os as _os
import warnings as _warnings

import numpy as _np

from . import _relief

__version__ = _relief.version
__all__ = ["CancelledError", "Image", "ReliefWarning", "height_udim", "operations", "prepare", "read", "write"]

CancelledError = _relief.CancelledError
CancelledError.__doc__ = "An operation stopped because its progress callable returned True."


class ReliefWarning(UserWarning):
    """Likely trouble with an input that relief went on with: an ambiguous
    green convention, NaNs replaced, float normals that look unsigned."""


def _listener(messages):
    # (stacklevel 3: this function, the operation's wrapper, its caller)
    def on_message(severity, text):
        if severity == "warning":
            _warnings.warn(text, ReliefWarning, stacklevel=3)
        if messages is not None:
            messages(severity, text)

    return on_message


class Image(_np.ndarray):
    """A numpy array with the image's metadata (a dict: numbers as numbers, the rest as text)."""

    def __new__(cls, array, metadata=None):
        obj = _np.asarray(array).view(cls)
        obj.metadata = dict(metadata or {})
        return obj

    def __array_finalize__(self, obj):
        self.metadata = dict(getattr(obj, "metadata", None) or {})


def operations():
    """The operation table: a list of dicts (name, summary, inputs, outputs,
    modifiers with type, choices, range, default and meaning)."""
    return _json.loads(_relief.operations_json())["operations"]


def _text(key, value):
    if isinstance(value, (bool, _np.bool_)):
        return "on" if value else "off"
    if isinstance(value, (int, float, _np.integer, _np.floating)):
        return str(value)
    if isinstance(value, (str, _os.PathLike)):
        return _os.fspath(value)
    raise ValueError(f"{key}={value!r}: give a string, a number or True/False")


def _is_imagebuf(image):
    return type(image).__name__ == "ImageBuf" and type(image).__module__.startswith("OpenImageIO")


def _from_imagebuf(buf):
    """(pixels, metadata) of an OpenImageIO.ImageBuf: the pixels in their
    stored type where relief reads that type as stored (uint8, uint16: UNORM,
    as a file of that type decodes; half; float), else as float32."""
    import OpenImageIO as oiio

    if buf.has_error or not buf.initialized:
        raise ValueError(f"the ImageBuf has no pixels: {buf.geterror() or 'not initialised'}")
    spec = buf.spec()
    stored = {"uint8": oiio.UINT8, "uint16": oiio.UINT16, "half": oiio.HALF}.get(str(spec.format), oiio.FLOAT)
    pixels = buf.get_pixels(stored)
    if pixels is None:
        raise ValueError(f"cannot read the ImageBuf's pixels: {buf.geterror()}")
    return pixels, {a.name: a.value for a in spec.extra_attribs}


def _metadata(image):
    if _is_imagebuf(image):
        return _from_imagebuf(image)[1]
    return dict(getattr(image, "metadata", None) or {})


def _pixels(array):
    if _is_imagebuf(array):
        array = _from_imagebuf(array)[0]
    a = _np.asarray(array)
    if a.dtype == _np.float64:  # numpy's default float: relief computes in float32
        a = a.astype(_np.float32)
    if not a.dtype.isnative:  # e.g. ">u2" from a big-endian file
        a = a.astype(a.dtype.newbyteorder("="))
    return a


def _operation(info):
    name = info["name"]
    inputs = [slot["name"] for slot in info["inputs"]]

    def run(*images, device="auto", progress=None, messages=None, **modifiers):
        if len(images) != len(inputs):
            raise ValueError(f"{name} takes {len(inputs)} image(s) ({', '.join(inputs)}), got {len(images)}")
        metadata = [_metadata(image) for image in images]
        pixels, meta = _relief.run(name, [_pixels(i) for i in images], metadata,
                                   [(k, _text(k, v)) for k, v in modifiers.items()], device,
                                   _listener(messages), progress)
        return Image(pixels, meta)

    lines = [f"{name}({', '.join(inputs)}, device='auto', progress=None, messages=None, **modifiers)"
             " -> relief.Image", "", info["summary"] + ".", "",
             "Modifiers:"]
    for m in info["modifiers"]:
        values = "|".join(m["choices"]) if m["type"] == "choice" else m["type"]
        if m["type"] != "choice" and m["choices"]:
            values += " or " + "|".join(m["choices"])
        where = f" [{m['applies_to']}]" if m["applies_to"] else ""
        lines.append(f"    {m['name']}={values} (default {m['default']}){where}: {m['meaning']}")
    run.__name__ = run.__qualname__ = name
    run.__doc__ = "\n".join(lines)
    return run


for _info in operations():
    globals()[_info["name"]] = _operation(_info)
    __all__.append(_info["name"])
del _info


def height_udim(tiles, device="auto", progress=None, messages=None, **modifiers):
    """height over the tiles of a UDIM set at once: tiles maps each tile
    number (1001 + u + 10 v, v up: 1011 sits above 1001) to its normal map,
    as a dict or (number, array) pairs. Returns a dict from the same numbers
    to relief.Image heights. udim="auto" (the default) joins the tiles whose
    slopes continue across their shared edge, "joint" solves the set as one
    surface (missing tiles weighted 0), "each" every tile alone; the other
    keywords are height's, progress= and messages= as for every operation."""
    pairs = list(tiles.items()) if isinstance(tiles, dict) else list(tiles)
    numbers = [int(n) for n, _ in pairs]
    images = [image for _, image in pairs]
    metadata = [_metadata(image) for image in images]
    results = _relief.run_tiles("height", numbers, [_pixels(i) for i in images], metadata,
                                [(k, _text(k, v)) for k, v in modifiers.items()], device,
                                _listener(messages), progress)
    return {n: Image(pixels, meta) for n, (pixels, meta) in zip(numbers, results)}


def prepare(width, height, device="auto"):
    """Sets up now (the device, its kernels, the FFT plans of that size) what
    a height of a width x height map needs, without the GIL: call it on a
    thread of your own while you read the map. Problems are left for the
    operation to raise."""
    _relief.prepare(device, int(width), int(height))


def read(path):
    """Reads an image as stored (uint8, uint16, float16 or float32 H x W x C),
    with its metadata, without colour conversion. Files of other types come
    as float32 (integers scaled to [0, 1]: pass range="unsigned" to decode
    such normals)."""
    pixels, meta = _relief.read(_os.fspath(path))
    return Image(pixels, meta)


def write(path, image, type="float", compression=""):
    """Writes an image atomically (a failure leaves no file and keeps an old
    one). type: float, half, uint16 or uint8; relief's signed results
    (heights, slopes, offsets: metadata relief:method) are mapped to integers
    as data = (value - 0.5) * scale, the scale stored in the file."""
    _relief.write(_os.fspath(path), _pixels(image), _metadata(image),
                  type, compression)
