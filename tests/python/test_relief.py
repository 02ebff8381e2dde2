# SPDX-License-Identifier: Apache-2.0
"""Tests of the Python package `relief` (run by ctest with Debian's
/usr/bin/python3 -m unittest; PYTHONPATH points at the package, RELIEF_CLI
at the command line, RELIEF_TEST_DATA at examples/data)."""
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
import unittest
import warnings

import numpy as np
import OpenImageIO as oiio

import relief

CLI = os.environ["RELIEF_CLI"]
DATA = os.environ["RELIEF_TEST_DATA"]
# The DEM sample's normal map cut to 400 x 336 (8-bit RGB, as stored):
# lengths of small primes, whose FFTs plan in half the time of its own
# 403 x 344 (31 and 43 need Bluestein's algorithm), which most of these
# tests would otherwise plan first.
_SAMPLE_DIR = tempfile.TemporaryDirectory()
NORMAL = os.path.join(_SAMPLE_DIR.name, "normal.png")
_sample = oiio.ImageBuf(os.path.join(DATA, "dem_jacksboro", "normal.png"))
if not oiio.ImageBufAlgo.cut(_sample, oiio.ROI(0, 400, 0, 336)).write(NORMAL):
    raise RuntimeError("cannot write " + NORMAL)
del _sample


def cli(*args):
    r = subprocess.run([CLI, *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"relief {' '.join(args)}: {r.stderr}")
    return r


class Doors(unittest.TestCase):
    """The same bytes give the same result through Python and the command line."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.normals = relief.read(NORMAL)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def path(self, name):
        return os.path.join(self.tmp.name, name)

    def cli_result(self, source, command):
        out = self.path("cli.exr")
        cli(source, command, "-o", out)
        return relief.read(out)

    def test_read_keeps_the_file_type(self):
        self.assertEqual(self.normals.dtype, np.uint8)
        self.assertEqual(self.normals.shape, (336, 400, 3))

    def test_uint8_height_equals_the_cli(self):
        for modifiers, command in [({}, "--height"),
                                   ({"normal": "opengl", "boundary": "periodic"},
                                    "--height:normal=opengl:boundary=periodic"),
                                   ({"rays": 8, "radius": 16.0, "skip": False},
                                    "--height:rays=8:radius=16:skip=off")]:
            with self.subTest(command):
                h = relief.height(self.normals, **modifiers)
                self.assertEqual(h.dtype, np.float32)
                self.assertEqual(h.shape, (336, 400, 1))
                np.testing.assert_array_equal(h, self.cli_result(NORMAL, command))

    def test_write_maps_signed_results_to_integers_and_back(self):
        h = relief.height(self.normals, normal="opengl")
        png = self.path("h16.png")
        relief.write(png, h, type="uint16")
        back = relief.read(png)
        scale = float(back.metadata["relief:height_scale"])
        data = (back.astype(np.float64) / 65535 - 0.5) * scale
        self.assertLess(np.abs(data - h).max(), scale / 65535)

    def test_write_is_atomic_and_reports_failure(self):
        target = self.path("keep.exr")
        relief.write(target, np.ones((4, 4, 1), np.float32))
        with open(target, "rb") as f:
            before = f.read()
        with self.assertRaises(RuntimeError):
            relief.write(self.path("no/such/folder/x.exr"), np.ones((4, 4, 1), np.float32))
        with self.assertRaises(RuntimeError):
            relief.write(self.path("x.unknownformat"), np.ones((4, 4, 1), np.float32))
        with open(target, "rb") as f:
            self.assertEqual(f.read(), before)
        self.assertEqual(sorted(os.listdir(self.tmp.name)).count("x.unknownformat"), 0)

class MoreDoors(unittest.TestCase):
    """The same bytes give the same result through Python and the command
    line: other pixel types, chains of operations, the checks."""

    setUpClass = classmethod(Doors.setUpClass.__func__)
    tearDownClass = classmethod(Doors.tearDownClass.__func__)
    path = Doors.path
    cli_result = Doors.cli_result

    def test_any_strides_give_the_c_ordered_arrays_result(self):
        # views (every other row, x reversed, a column band), Fortran order,
        # channels reversed, and a broadcast: each as its C-ordered copy
        n = self.normals
        for view in (n[::2], n[:, ::-1], n[:, 100:300], np.asfortranarray(n), n[..., ::-1],
                     np.broadcast_to(n[:1], n.shape)):
            np.testing.assert_array_equal(relief.height(view, normal="opengl", boundary="free"),
                                          relief.height(np.ascontiguousarray(view), normal="opengl",
                                                        boundary="free"))

    def test_a_one_channel_view_is_copied_once(self):
        # A height seen through a strided channel axis (shape h, w, 1, the
        # channel 12 bytes apart): one channel is packed whatever its
        # stride, so relief reads it as it is; numpy makes no copy of it.
        h3 = np.zeros((512, 512, 3), np.float32)
        h3[..., 0] = np.sin(np.arange(512, dtype=np.float32) * 0.05)[None, :] * 4
        view = h3[..., ::3]
        dense = np.ascontiguousarray(view)
        peaks = []
        for a in (dense, view):
            tracemalloc.start()  # numpy's allocations are traced
            try:
                got = relief.tessellation(a)  # (a result of a few KiB: the copy would be the peak)
                peaks.append(tracemalloc.get_traced_memory()[1])
            finally:
                tracemalloc.stop()
        np.testing.assert_array_equal(got, relief.tessellation(dense))
        self.assertLess(peaks[1], peaks[0] + view.size * 4 // 2)  # (a copy: 1 MiB more)

    def test_uint16_and_half_inputs_equal_the_cli_on_the_same_bytes(self):
        n16 = (self.normals.astype(np.uint16) * 257).astype(np.uint16)
        png16 = self.path("n16.png")
        relief.write(png16, n16, type="uint16")
        self.assertEqual(relief.read(png16).dtype, np.uint16)
        np.testing.assert_array_equal(relief.height(n16.astype(">u2"), normal="opengl"),
                                      relief.height(n16, normal="opengl"))  # byte order is the array's business
        np.testing.assert_array_equal(relief.height(n16, normal="opengl"),
                                      self.cli_result(png16, "--height:normal=opengl"))
        nh = (self.normals.astype(np.float32) / 255 * 2 - 1).astype(np.float16)
        exr = self.path("nh.exr")
        relief.write(exr, nh, type="half")
        self.assertEqual(relief.read(exr).dtype, np.float16)
        np.testing.assert_array_equal(relief.height(nh, normal="opengl"),
                                      self.cli_result(exr, "--height:normal=opengl"))
        # float32 holding the same signed values: the same result as half
        np.testing.assert_array_equal(relief.height(nh.astype(np.float32), normal="opengl"),
                                      relief.height(nh, normal="opengl"))


    def test_correct_and_bake_chain_like_the_cli(self):
        h = relief.height(self.normals, normal="opengl", boundary="periodic")
        off = relief.correct(h, levels=1, iterations=3)
        self.assertEqual(off.metadata.get("relief:method"), "correct")
        self.assertEqual(off.metadata.get("relief:boundary"), "periodic")
        baked = relief.bake(self.normals, off)
        out = self.path("baked.exr")
        cli(NORMAL, NORMAL, "--height:normal=opengl:boundary=periodic", "--correct:levels=1:iterations=3",
            "-o", self.path("off.exr"), "--bake", "-d", "float", "-o", out)
        np.testing.assert_array_equal(off, relief.read(self.path("off.exr")))
        np.testing.assert_array_equal(baked, relief.read(out))


    def test_checks_of_a_height_equal_the_cli(self):
        h = relief.height(self.normals, normal="opengl", boundary="free")
        hpath = self.path("h.exr")
        relief.write(hpath, h)
        n = relief.normals(h, normal="directx", scale=2)
        self.assertEqual(n.shape, (336, 400, 3))
        np.testing.assert_array_equal(n, self.cli_result(hpath, "--normals:normal=directx:scale=2"))
        levels = relief.tessellation(h, patch=16, error=0.25)
        self.assertEqual(levels.shape, (21, 25, 1))
        np.testing.assert_array_equal(levels, self.cli_result(hpath, "--tessellation:patch=16:error=0.25"))
        mesh = self.path("m.obj")
        kept = relief.mesh(h, out=mesh)
        np.testing.assert_array_equal(kept, h)
        self.assertTrue(open(mesh).readline().startswith("# relief"))
        sheet = relief.preview(self.normals, h, normal="opengl", light="90,30")
        self.assertEqual(sheet.shape[2], 3)
        self.assertGreaterEqual(sheet.shape[1], 1024)
        with self.assertRaises(ValueError):
            relief.mesh(h, out=self.path("m.stl"))


class Refusals(unittest.TestCase):
    def setUp(self):
        self.n = np.full((16, 16, 3), 128, np.uint8)
        self.n[..., 2] = 255

    def refused(self, fn, *args, contains, **kw):
        with self.assertRaises(ValueError) as e:
            fn(*args, **kw)
        self.assertIn(contains, str(e.exception))

    def test_bad_values_raise_value_error_with_relief_message(self):
        self.refused(relief.height, self.n, rays=-3, contains="rays=-3 must be an integer in [1, 4096]")
        self.refused(relief.height, self.n, phase=1.5, contains="phase=1.5 is out of range")
        self.refused(relief.height, self.n, normal="sideways", contains="normal=sideways is not one of")
        self.refused(relief.height, self.n, colour="red", contains="unknown modifier 'colour'")
        self.refused(relief.height, self.n, method="poisson", rays=8, contains="apply to method=rays")
        self.refused(relief.correct, self.n[..., :1], theta=21, contains="theta=21 is out of range")
        self.refused(relief.bake, self.n, self.n, wrap="mirror", contains="wrap=mirror")
        self.refused(relief.height, self.n, rays=[1], contains="give a string, a number or True/False")

    def test_bad_images_raise_value_error(self):
        self.refused(relief.height, np.zeros((8, 8, 7), np.uint8), contains="7 channel(s)")
        self.refused(relief.height, np.zeros((8, 8, 3), np.int32), contains="uint8, uint16, float16 or float32")
        self.refused(relief.height, np.zeros((8,), np.uint8), contains="H x W or H x W x C")
        self.refused(relief.bake, self.n, contains="bake takes 2 image(s)")
        # write takes any image of 1 to 4096 channels
        path = os.path.join(tempfile.mkdtemp(), "w.exr")
        self.refused(relief.write, path, np.zeros((1, 1, 4097), np.float32),
                     contains="write: input 'image' has 4097 channel(s); write takes 1 to 4096")
        self.assertFalse(os.path.exists(path))
        relief.write(path, np.zeros((1, 1, 4096), np.float32))
        self.assertEqual(relief.read(path).shape, (1, 1, 4096))
        # a name with a NUL byte: refused, not cut at the NUL
        cut = os.path.join(os.path.dirname(path), "cut.exr")
        with self.assertRaises((ValueError, RuntimeError, OSError)) as e:
            relief.write(cut + "\0.png", np.zeros((1, 1, 1), np.float32))
        self.assertIn("the name holds a NUL byte", str(e.exception))
        self.assertFalse(os.path.exists(cut))

    def test_sizes_are_refused_before_any_copy(self):
        # 3 floats that claim 30 GB: refused from the shape, never copied
        huge = np.broadcast_to(np.zeros(3, np.float32), (50000, 50000, 3))
        self.refused(relief.height, huge, contains="a 50000x50000 map is larger than this version handles")
        big = np.broadcast_to(np.zeros(3, np.float32), (8000, 8000, 3))
        os.environ["RELIEF_MEMORY_LIMIT"] = "64M"
        tracemalloc.start()  # numpy's copies are traced
        try:
            self.refused(relief.height, big,
                         contains="(8000x8000x3) needs 732.4 MiB of memory, RELIEF_MEMORY_LIMIT=64M allows 64.0 MiB")
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
            del os.environ["RELIEF_MEMORY_LIMIT"]
        self.assertLess(peak, 64 << 20)  # the 768 MB were never copied

    def test_the_operations_memory_estimate_refuses_before_the_copy(self):
        # A 40000^2 uint8 normal map (4.8 GB) whose copy fits the limit, but
        # whose height does not: refused at once by the estimate, never
        # copied (the run had copied it for minutes, then refused it).
        huge = np.broadcast_to(np.zeros(3, np.uint8), (40000, 40000, 3))
        os.environ["RELIEF_MEMORY_LIMIT"] = "6G"
        try:
            before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            start = time.monotonic()
            with self.assertRaises(RuntimeError) as e:
                relief.height(huge, normal="opengl")
            seconds = time.monotonic() - start
            grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before  # KiB
        finally:
            del os.environ["RELIEF_MEMORY_LIMIT"]
        # (the device's memory or the limit, whichever is short first)
        self.assertIn("height: the Poisson integration of a 40000x40000 map needs", str(e.exception))
        self.assertLess(grown, 256 << 10)  # no copy: under 256 MiB more at the peak
        self.assertLess(seconds, 10.0)  # (about 0.1 s here; a copy took minutes)
        # the tiles of a UDIM set alike, each checked before any is copied
        os.environ["RELIEF_MEMORY_LIMIT"] = "6G"
        try:
            with self.assertRaises(RuntimeError) as e:
                relief.height_udim({1001: huge, 1002: huge}, normal="opengl")
        finally:
            del os.environ["RELIEF_MEMORY_LIMIT"]
        self.assertIn("of a 40000x40000 map needs", str(e.exception))
        self.assertLess(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before, 256 << 10)

    def test_a_failed_run_raises_runtime_error(self):
        with self.assertRaises(RuntimeError) as e:
            relief.height(self.n, mask="alpha")
        self.assertIn("4 channels", str(e.exception))


class Table(unittest.TestCase):
    def test_operations_list_the_table(self):
        ops = {op["name"]: op for op in relief.operations()}
        for name in ("slopes", "height", "correct", "bake", "normals", "tessellation", "mesh", "preview"):
            self.assertIn(name, ops)
            self.assertTrue(callable(getattr(relief, name)))
            self.assertIn(ops[name]["summary"], getattr(relief, name).__doc__)
        rays = {m["name"]: m for m in ops["height"]["modifiers"]}["rays"]
        self.assertEqual((rays["type"], rays["min"], rays["max"], rays["default"]), ("integer", 1, 4096, "32"))
        self.assertEqual([s["name"] for s in ops["bake"]["inputs"]], ["texture", "offsets"])

    def test_every_default_is_accepted_and_changes_nothing(self):
        n = np.full((16, 16, 3), 128, np.uint8)
        n[..., 2] = 255
        n[5:9, 5:9, 0] = 160
        ops = {op["name"]: op for op in relief.operations()}
        base = relief.height(n, normal="opengl")
        for m in ops["height"]["modifiers"]:
            if m["applies_to"] or m["default"] == "none" or m["name"] == "normal":
                continue
            with self.subTest(m["name"]):
                np.testing.assert_array_equal(relief.height(n, normal="opengl", **{m["name"]: m["default"]}), base)


class Keywords(unittest.TestCase):
    """Every keyword of every operation reaches the engine: a value other
    than the default gives what the command line gives for the same
    modifier (pixels and relief:* metadata), and changes the result where it
    should. A modifier added to the table without a case here fails."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        t = cls.tmp.name
        y, x = np.mgrid[0:20, 0:24]
        nx = 0.5 * np.sin(2 * np.pi * x / 12) * np.cos(2 * np.pi * y / 20)
        ny = 0.4 * np.cos(2 * np.pi * y / 20 * 3) + 0.2 * (x > 12)
        n = np.stack([nx, ny, np.sqrt(np.clip(1 - nx**2 - ny**2, 0.05, 1))], -1)
        n8 = np.round((n * 0.5 + 0.5) * 255).astype(np.uint8)
        alpha = np.where((x - 12) ** 2 + (y - 10) ** 2 < 30, 255, 40).astype(np.uint8)
        relief.write(os.path.join(t, "n.png"), n8, type="uint8")
        relief.write(os.path.join(t, "na.png"), np.dstack([n8, alpha]), type="uint8")
        relief.write(os.path.join(t, "w.png"), alpha, type="uint8")
        relief.write(os.path.join(t, "nf.exr"), (n * 0.5 + 0.5).astype(np.float32))
        rng = np.random.default_rng(3)
        relief.write(os.path.join(t, "t.png"), rng.integers(0, 256, (20, 24, 3)).astype(np.uint8), type="uint8")
        relief.write(os.path.join(t, "env.png"), rng.integers(0, 256, (8, 16, 3)).astype(np.uint8), type="uint8")
        h = relief.height(relief.read(os.path.join(t, "n.png")), normal="opengl", boundary="periodic")
        relief.write(os.path.join(t, "h.exr"), h)
        relief.write(os.path.join(t, "off.exr"), relief.correct(h, levels=1, iterations=3))
        y, x = np.mgrid[0:32, 0:32]
        hills = 3 * np.sin(2 * np.pi * x / 32) * np.cos(4 * np.pi * y / 32) + (x > 20)
        relief.write(os.path.join(t, "hills.exr"), hills.astype(np.float32))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    # (operation, input files, context, keywords, the result differs from
    # the context's alone; None: refused alike). The context (method=rays
    # for the rays' own keywords; a scale for hills.exr, which has no relief
    # metadata) is given to both runs and to the default's.
    CASES = [
        ("slopes", ["n.png"], {}, {"normal": "directx"}, True),
        ("slopes", ["n.png"], {}, {"max_angle": 30}, True),
        ("slopes", ["nf.exr"], {}, {"range": "unsigned"}, True),
        ("height", ["n.png"], {}, {"normal": "directx"}, True),
        ("height", ["n.png"], {}, {"max_angle": 20}, True),
        ("height", ["nf.exr"], {}, {"range": "unsigned"}, True),
        ("height", ["n.png"], {}, {"method": "rays"}, True),
        ("height", ["n.png"], {}, {"boundary": "free"}, True),
        ("height", ["n.png"], {"method": "rays"}, {"boundary": "clip"}, True),
        ("height", ["n.png"], {}, {"highpass": 4}, True),
        ("height", ["n.png"], {}, {"udim": "each"}, False),  # one map: a UDIM set's mode changes nothing
        ("height", ["na.png"], {}, {"mask": "alpha"}, True),
        ("height", ["n.png"], {}, {"mask": "w.png"}, True),
        ("height", ["n.png"], {"method": "rays"}, {"impl": "reference"}, True),
        ("height", ["n.png"], {"method": "rays"}, {"rays": 8}, True),
        ("height", ["n.png"], {"method": "rays"}, {"radius": 4}, True),
        ("height", ["n.png"], {"method": "rays"}, {"phase": 0.25}, True),
        ("height", ["n.png"], {"method": "rays", "impl": "reference"}, {"directions": "exact"}, True),
        ("height", ["n.png"], {"method": "rays"}, {"skip": False}, False),  # skipping is exact
        ("correct", ["h.exr"], {}, {"scale": 0.3}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"theta": 3}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"nodes": "center"}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"boundary": "periodic"}, True),  # auto: fixed
        ("correct", ["hills.exr"], {"scale": 0.05}, {"fix": "height:0:1"}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"fix": "w.png"}, None),  # sizes differ: refused alike
        ("correct", ["h.exr"], {}, {"fix": "w.png"}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"iterations": 2}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"tolerance": 0.1}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"levels": 1}, True),
        ("correct", ["h.exr"], {}, {"threshold": 0.5}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"skip": False}, False),  # skipping is exact
        ("correct", ["hills.exr"], {"scale": 0.05}, {"search": "golden"}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"relax": 1.2}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"hats": "always"}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"global": "off"}, True),
        ("correct", ["hills.exr"], {"scale": 0.05}, {"polish": 0}, True),
        ("bake", ["t.png", "off.exr"], {}, {"filter": "bicubic"}, True),
        ("bake", ["t.png", "off.exr"], {}, {"colorspace": "linear"}, True),
        ("bake", ["t.png", "off.exr"], {}, {"kind": "data"}, True),
        ("bake", ["t.png", "off.exr"], {}, {"wrap": "clamp"}, True),
        ("normals", ["h.exr"], {}, {"normal": "directx"}, True),
        ("normals", ["h.exr"], {}, {"scale": 2}, True),
        ("normals", ["h.exr"], {}, {"boundary": "free"}, True),
        ("tessellation", ["h.exr"], {}, {"patch": 8}, True),
        ("tessellation", ["h.exr"], {}, {"error": 0.1}, True),
        ("tessellation", ["h.exr"], {}, {"scale": 3}, True),
        ("preview", ["n.png", "h.exr"], {}, {"normal": "directx"}, True),
        ("preview", ["n.png", "h.exr"], {}, {"max_angle": 30}, True),
        ("preview", ["nf.exr", "h.exr"], {}, {"range": "unsigned"}, True),
        ("preview", ["n.png", "h.exr"], {}, {"light": "90,30"}, True),
        ("preview", ["n.png", "h.exr"], {}, {"env": "env.png"}, True),
        ("preview", ["n.png", "h.exr"], {}, {"boundary": "free"}, True),
    ]

    def files(self, names):
        return [os.path.join(self.tmp.name, n) for n in names]

    def named(self, kw):  # file names as the same absolute path both ways
        return {k: os.path.join(self.tmp.name, v) if str(v).endswith(".png") else v for k, v in kw.items()}

    def python_run(self, op, files, kw):
        return getattr(relief, op)(*[relief.read(f) for f in files], **self.named(kw))

    def cli_runs(self, runs):
        """The command line's result of each (op, files, keywords), as
        (status, message, image or None), all from one --batch process: the
        same parsing as a run of its own, without a process and a device
        set-up per case (52 of them took 46 s that way)."""
        text = {True: "on", False: "off"}  # the command line's text written here, not by the package
        jobs, outs = os.path.join(self.tmp.name, "jobs.txt"), []
        with open(jobs, "w") as f:
            for i, (op, files, kw) in enumerate(runs):
                mods = "".join(f":{k}={text.get(v, v) if isinstance(v, bool) else v}"
                               for k, v in self.named(kw).items())
                outs.append(os.path.join(self.tmp.name, f"cli{i}.exr"))
                f.write(" ".join([*files, f"--{op}{mods}", "-d", "float", "-o", outs[-1]]) + "\n")
        log = os.path.join(self.tmp.name, "jobs.jsonl")
        subprocess.run([CLI, "--batch", jobs, "--log", log], capture_output=True, text=True, cwd=self.tmp.name)
        with open(log) as f:
            records = {r["job"]: r for r in map(json.loads, f)}
        self.assertEqual(sorted(records), list(range(len(runs))))
        return [(records[i]["status"], records[i].get("message", ""),
                 relief.read(outs[i]) if records[i]["status"] == "ok" else None) for i in range(len(runs))]

    def test_every_keyword_gives_what_the_command_line_gives(self):
        covered, bases = set(), {}
        cli = self.cli_runs([(op, self.files(names), {**context, **own}) for op, names, context, own, _ in self.CASES])
        for (op, names, context, own, changes), (status, message, expected) in zip(self.CASES, cli):
            covered.update((op, k) for k in own)
            kw = {**context, **own}
            with self.subTest(op=op, kw=kw):
                files = self.files(names)
                if changes is None:
                    self.assertEqual(status, "failed")
                    with self.assertRaises((ValueError, RuntimeError)):
                        self.python_run(op, files, kw)
                    continue
                self.assertEqual(status, "ok", message)
                got = self.python_run(op, files, kw)
                np.testing.assert_array_equal(got, expected)
                self.assertEqual({k: v for k, v in got.metadata.items() if k.startswith("relief:")},
                                 {k: v for k, v in expected.metadata.items() if k.startswith("relief:")})
                key = (op, tuple(names), tuple(context.items()))
                if key not in bases:
                    bases[key] = self.python_run(op, files, context)
                same = bases[key].shape == got.shape and np.array_equal(bases[key], got)
                self.assertEqual(not same, changes, "the keyword changed nothing" if changes else "")
        for op in relief.operations():
            for m in op["modifiers"]:
                if op["name"] != "mesh":  # mesh: test_mesh_keywords_reach_the_file
                    self.assertIn((op["name"], m["name"]), covered)

    def test_keyword_values_become_the_command_line_text(self):
        # skip= is exact either way, so on/off shows in no result: the text itself
        self.assertEqual([relief._text("skip", v) for v in (True, False, np.True_, np.False_)],
                         ["on", "off", "on", "off"])
        self.assertEqual([relief._text("k", v) for v in (8, 0.25, np.float32(0.5), np.int64(3), "a b")],
                         ["8", "0.25", "0.5", "3", "a b"])
        import pathlib
        self.assertEqual(relief._text("mask", pathlib.Path("/maps/w.png")), "/maps/w.png")

    def test_mesh_keywords_reach_the_file(self):
        h = relief.read(os.path.join(self.tmp.name, "h.exr"))
        files = {}
        for kw in ({}, {"patch": 8}, {"error": 0.1}, {"scale": 3}):
            with self.subTest(kw=kw):
                mine = os.path.join(self.tmp.name, "py.obj")
                relief.mesh(h, out=mine, **kw)
                theirs = os.path.join(self.tmp.name, "cli.obj")
                mods = "".join(f":{k}={v}" for k, v in kw.items())
                cli(os.path.join(self.tmp.name, "h.exr"), f"--mesh:out={theirs}{mods}")
                with open(mine, "rb") as a, open(theirs, "rb") as b:
                    files[str(kw)] = a.read()
                    # the command line's first line adds the digest --update reads
                    self.assertEqual(files[str(kw)].split(b"\n", 1)[1], b.read().split(b"\n", 1)[1])
        self.assertEqual(len(set(files.values())), 4)

    def test_the_device_keyword_reaches_the_engine(self):
        n = relief.read(os.path.join(self.tmp.name, "n.png"))
        # against the command line's --device, not the default: under
        # RELIEF_DEVICE (the suite on Rusticl) auto is another device
        out = os.path.join(self.tmp.name, "cpu.exr")
        cli(os.path.join(self.tmp.name, "n.png"), "--device", "cpu", "--height", "-d", "float", "-o", out)
        np.testing.assert_array_equal(relief.height(n, device="cpu"), relief.read(out))
        for op, inputs in (("height", [n]), ("slopes", [n])):
            with self.assertRaises(RuntimeError) as e:
                getattr(relief, op)(*inputs, device="9:9")
            self.assertIn("9:9", str(e.exception))


def numpy_least_squares(g, periodic_x, periodic_y):
    """Frankot-Chellappa in numpy, independent of relief: the slopes' even
    extension across each free axis (gx odd across the vertical edges, gy
    across the horizontal ones), the FFT of the torus, the mean and the
    Nyquist terms dropped, cropped back."""
    gx, gy = g[..., 0].astype(np.float64), g[..., 1].astype(np.float64)
    h, w = gx.shape
    if not periodic_x:
        gx, gy = np.concatenate([gx, -gx[:, ::-1]], 1), np.concatenate([gy, gy[:, ::-1]], 1)
    if not periodic_y:
        gx, gy = np.concatenate([gx, gx[::-1, :]], 0), np.concatenate([gy, -gy[::-1, :]], 0)
    m, n = gx.shape
    wx = 2 * np.pi * np.fft.fftfreq(n)[None, :]
    wy = 2 * np.pi * np.fft.fftfreq(m)[:, None]
    w2 = wx**2 + wy**2
    w2[0, 0] = 1.0
    spectrum = -1j * (wx * np.fft.fft2(gx) + wy * np.fft.fft2(gy)) / w2
    spectrum[0, 0] = 0.0
    if n % 2 == 0:
        spectrum[:, n // 2] = 0.0
    if m % 2 == 0:
        spectrum[m // 2, :] = 0.0
    out = np.real(np.fft.ifft2(spectrum))[:h, :w]
    return out - out.mean()


class PerAxisBoundary(unittest.TestCase):
    def test_one_periodic_axis_equals_numpy_and_fits_a_map_that_tiles_along_it(self):
        # A height that tiles along x and not along y (a trim sheet's kind),
        # its normals by central differences that wrap along x only.
        w, h = 96, 72
        x, y = np.arange(w)[None, :], np.arange(h)[:, None]
        rng = np.random.default_rng(3)
        truth = np.zeros((h, w))
        for k in range(1, 5):
            for power in (1, 2, 3):
                truth += 6.0 * rng.normal() / (k + power) * np.cos(2 * np.pi * k * x / w + rng.uniform(0, 6)) * (y / h) ** power
        gx = (np.roll(truth, -1, 1) - np.roll(truth, 1, 1)) / 2
        gy = np.gradient(truth, axis=0)
        normals = np.stack([-gx, gy, np.ones_like(truth)], -1)  # OpenGL: G = -n_y, rows run down
        normals = (normals / np.linalg.norm(normals, axis=2, keepdims=True)).astype(np.float32)
        g = np.asarray(relief.slopes(normals, normal="opengl"))
        truth -= truth.mean()
        error = {}
        for word, px, py in (("periodic,free", True, False), ("free,periodic", False, True),
                             ("periodic", True, True), ("free", False, False)):
            got = np.asarray(relief.height(normals, normal="opengl", boundary=word))[..., 0]
            want = numpy_least_squares(g, px, py)
            self.assertLess(np.abs(got - want).max(), 1e-4 * want.std(), word)
            error[word] = np.sqrt(((got - truth) ** 2).mean()) / truth.std()
        # The default decides each axis on its own: the same as periodic,free.
        default = np.asarray(relief.height(normals, normal="opengl"))[..., 0]
        np.testing.assert_array_equal(default, np.asarray(relief.height(normals, normal="opengl",
                                                                         boundary="periodic,free"))[..., 0])
        # Periodic along x and free along y fits it best (measured: rms error
        # 0.0029 of its std; both free 0.0032, the other two 0.34 and 0.35).
        self.assertLess(1.05 * error["periodic,free"], error["free"], error)
        self.assertLess(50 * error["periodic,free"], min(error["periodic"], error["free,periodic"]), error)


class Udim(unittest.TestCase):
    """height_udim: a set's tiles by number, as the command line's <UDIM>."""

    @classmethod
    def setUpClass(cls):
        cls.normals = relief.read(NORMAL)  # 2 x 2 tiles of 200 x 168
        n = cls.normals
        # v up: 1011 and 1012 are the top half.
        cls.tiles = {1001: n[168:, :200], 1002: n[168:, 200:], 1011: n[:168, :200], 1012: n[:168, 200:]}

    def test_joint_is_the_assembled_map_cut_into_tiles(self):
        whole = np.asarray(relief.height(np.ascontiguousarray(self.normals), boundary="free"))
        got = relief.height_udim(self.tiles, udim="joint", boundary="free")
        self.assertEqual(sorted(got), [1001, 1002, 1011, 1012])
        for n, (rows, cols) in {1001: (slice(168, None), slice(0, 200)), 1002: (slice(168, None), slice(200, None)),
                                1011: (slice(0, 168), slice(0, 200)), 1012: (slice(0, 168), slice(200, None))}.items():
            np.testing.assert_array_equal(np.asarray(got[n]), whole[rows, cols], str(n))
        self.assertEqual(got[1001].metadata["relief:udim"], "joint 1001,1002,1011,1012")

    def test_each_is_every_tile_alone_and_pairs_work_as_a_dict(self):
        got = relief.height_udim(list(self.tiles.items()), udim="each")
        for n, tile in self.tiles.items():
            np.testing.assert_array_equal(np.asarray(got[n]), np.asarray(relief.height(tile)), str(n))

    def test_the_order_given_does_not_matter(self):
        want = relief.height_udim(self.tiles, boundary="free")
        for order in ([1012, 1001, 1011, 1002], [1002, 1012, 1001, 1011]):
            got = relief.height_udim([(n, self.tiles[n]) for n in order], boundary="free")
            self.assertEqual(list(got), order)
            for n in order:
                np.testing.assert_array_equal(np.asarray(got[n]), np.asarray(want[n]), str(n))
                self.assertEqual(got[n].metadata, want[n].metadata)

    def test_messages_progress_cancel_and_device_reach_the_set(self):
        heard, done = [], []
        relief.height_udim(self.tiles, udim="joint", boundary="free",
                           messages=lambda s, t: heard.append((s, t)), progress=done.append)
        self.assertIn(("notice", "udim: 1001,1002,1011,1012 solved as one surface (2x2 tiles, 400x336 texels)"),
                      heard)
        self.assertEqual((done[0], done[-1]), (0.0, 1.0))
        self.assertEqual(done, sorted(done))
        with self.assertRaises(relief.CancelledError):
            relief.height_udim(self.tiles, progress=lambda f: True)
        with self.assertRaisesRegex(RuntimeError, "9:9"):
            relief.height_udim(self.tiles, device="9:9")

    def test_bad_sets_raise(self):
        with self.assertRaisesRegex(RuntimeError, "1001"):
            relief.height_udim({1001: self.tiles[1001], 1002: self.tiles[1002][:100]}, udim="joint")
        with self.assertRaisesRegex(ValueError, "udim"):
            relief.height_udim(self.tiles, udim="sometimes")
        # tile numbers out of range or twice: ValueError, before any work
        with self.assertRaisesRegex(ValueError, "1001 to 1999, got 2000"):
            relief.height_udim({1001: self.tiles[1001], 2000: self.tiles[1002]})
        with self.assertRaisesRegex(ValueError, "tile 1001 is given twice"):
            relief.height_udim([(1001, self.tiles[1001]), (1001, self.tiles[1002])])


class UdimCommandLine(unittest.TestCase):
    """height_udim equals the command line's <UDIM> on the same files."""

    setUpClass = classmethod(Udim.setUpClass.__func__)  # the same set of tiles

    def test_equals_the_command_line_on_the_same_files(self):
        with tempfile.TemporaryDirectory() as d:
            for n, tile in self.tiles.items():
                self.assertTrue(oiio.ImageBuf(np.ascontiguousarray(tile)).write(os.path.join(d, f"n.{n}.png")))
            read = {n: relief.read(os.path.join(d, f"n.{n}.png")) for n in self.tiles}
            for mods in ([], ["udim=joint", "boundary=free"], ["udim=each"]):
                cli(os.path.join(d, "n.<UDIM>.png"), "--height" + "".join(":" + m for m in mods),
                    "-o", os.path.join(d, "h.<UDIM>.exr"))
                got = relief.height_udim(read, **dict(m.split("=") for m in mods))
                for n in self.tiles:
                    want = relief.read(os.path.join(d, f"h.{n}.exr"))
                    np.testing.assert_array_equal(np.asarray(got[n]), np.asarray(want), f"{mods} {n}")
                    self.assertEqual(got[n].metadata.get("relief:udim"), want.metadata.get("relief:udim"))


class Callbacks(unittest.TestCase):
    """progress=, messages=, ReliefWarning, and what stops an operation."""

    flat = np.dstack([np.zeros((64, 64, 2), np.float32), np.ones((64, 64), np.float32)])
    # steep columns: a correction of many iterations
    cliffs = (np.indices((256, 256)).sum(0) % 32 > 16).astype(np.float32)

    def test_messages_and_progress_reach_their_callables(self):
        heard = []
        relief.height(self.flat, normal="opengl", messages=lambda s, t: heard.append((s, t)),
                      progress=lambda f: heard.append(("progress", f)))
        fractions = [f for s, f in heard if s == "progress"]
        self.assertEqual((fractions[0], fractions[-1]), (0.0, 1.0))
        self.assertEqual(fractions, sorted(fractions))
        self.assertIn(("info", "method: poisson (the default; method=rays for rays)"), heard)
        self.assertTrue(any(s == "notice" and t.startswith("boundary: periodic") for s, t in heard))
        steps = []
        relief.correct(self.cliffs, scale=0.3, levels=1, iterations=20, progress=steps.append)
        self.assertGreater(len(steps), 20)  # one a sweep, besides 0 and 1
        self.assertEqual(steps, sorted(steps))

    def test_relief_called_from_its_own_callback_is_refused_not_deadlocked(self):
        inner = []

        def call_again(_):
            try:
                relief.height(self.flat, normal="opengl")
                inner.append("ran")
            except RuntimeError as e:
                inner.append(str(e))

        relief.correct(self.cliffs, scale=0.3, levels=1, iterations=3, progress=call_again)
        self.assertGreater(len(inner), 2)
        for said in inner:
            self.assertIn("called from inside a message, progress or cancel callback", said)
        heard = []
        relief.height(self.flat, normal="opengl",
                      messages=lambda s, t: heard.append(call_again(None)))
        self.assertTrue(heard)
        self.assertIn("called from inside", inner[-1])
        relief.height(self.flat, normal="opengl")  # and afterwards freely again

    def test_warnings_are_relief_warnings(self):
        heard = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            relief.height(self.flat, messages=lambda s, t: heard.append(s))
        self.assertEqual([w.category for w in caught], [relief.ReliefWarning])
        self.assertIn("normal convention is ambiguous", str(caught[0].message))
        self.assertEqual(caught[0].filename, __file__)  # points at the caller
        self.assertIn("warning", heard)
        with warnings.catch_warnings():
            warnings.simplefilter("error", relief.ReliefWarning)
            with self.assertRaises(relief.ReliefWarning):
                relief.height(self.flat)

    def test_a_true_answer_from_progress_cancels(self):
        seen = []

        def stop_early(f):
            seen.append(f)
            return f > 0.05

        with self.assertRaises(relief.CancelledError) as e:
            relief.correct(self.cliffs, scale=0.3, levels=1, iterations=500, progress=stop_early)
        self.assertEqual(str(e.exception), "correct: cancelled")
        self.assertIsInstance(e.exception, RuntimeError)
        self.assertLess(seen[-1], 0.2)  # nothing was reported after it
        with self.assertRaises(relief.CancelledError):  # before any work
            relief.height(self.flat, progress=lambda f: True)
        # the reference rays, whose bands of rows (about 47 here) are ordinary
        # kernel launches (no FFT, no correction solver): they stop too
        seen.clear()
        normals = relief.normals(self.cliffs * 30.0, boundary="free")
        with self.assertRaises(relief.CancelledError):
            relief.height(normals, method="rays", impl="reference", rays=64, radius=256, boundary="clip",
                          normal="opengl", progress=stop_early)
        self.assertLess(seen[-1], 0.5)

    def test_an_exception_in_a_callback_stops_the_operation_and_is_raised(self):
        calls = []

        def fails(f):
            calls.append(f)
            if f > 0.05:
                raise KeyError("from the callback")

        with self.assertRaises(KeyError):
            relief.correct(self.cliffs, scale=0.3, levels=1, iterations=500, progress=fails)
        self.assertLess(calls[-1], 0.2)
        with self.assertRaises(ZeroDivisionError):
            relief.height(self.flat, normal="opengl", messages=lambda s, t: 1 / 0)

    def test_ctrl_c_stops_a_running_operation(self):
        big = np.tile(self.cliffs, (4, 4))  # 1024^2: seconds of correction
        timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
        start = time.monotonic()
        timer.start()
        with self.assertRaises(KeyboardInterrupt):
            relief.correct(big, scale=0.3)
        stopped = time.monotonic() - start
        self.assertGreaterEqual(stopped, 0.5)
        self.assertLess(stopped, 3.0)  # the whole correction takes about 20 s here
        # and relief works on
        self.assertEqual(relief.height(self.flat, normal="opengl").shape, (64, 64, 1))


class Quiet(unittest.TestCase):
    """relief writes nothing to stdout or stderr: the image library's own
    lines reach messages= as debug, or nowhere."""

    def test_a_damaged_file_prints_nothing_and_its_library_line_is_a_debug_message(self):
        with tempfile.TemporaryDirectory() as tmp:
            bad = os.path.join(tmp, "cut.png")
            with open(NORMAL, "rb") as f, open(bad, "wb") as out:
                out.write(f.read()[:5000])
            code = f"import relief\ntry:\n    relief.read({bad!r})\nexcept RuntimeError:\n    pass\n"
            r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
            self.assertEqual((r.returncode, r.stdout, r.stderr), (0, "", ""))
            heard = []
            n = relief.read(NORMAL)
            with self.assertRaises(RuntimeError) as e:
                relief.height(n, normal="opengl", mask=bad, messages=lambda s, t: heard.append((s, t)))
            self.assertIn("hit end of file", str(e.exception))
            self.assertIn(("debug", "libpng error: IDAT: Read error: hit end of file"), heard)


class NonUtf8Names(unittest.TestCase):
    """A file name that is not UTF-8 keeps every --log line valid JSON and comes
    back exactly: its other bytes are \\udcXX, Python's surrogateescape."""

    def test_the_log_gives_the_bytes_back_and_relief_slurm_counts_the_job(self):
        with tempfile.TemporaryDirectory() as tmp:
            t = os.fsencode(tmp)
            name, out = os.path.join(t, b"n\xff\xfe.png"), os.path.join(t, b"h\xff.exr")
            shutil.copy(NORMAL, name)
            jobs, logs = os.path.join(t, b"jobs.txt"), os.path.join(t, b"logs")
            os.mkdir(logs)
            with open(jobs, "wb") as f:
                f.write(b"'" + name + b"' --height:normal=opengl -o '" + out + b"'\n")
                f.write(b"'" + os.path.join(t, b"missing\xff.png") + b"' --height -o x.exr\n")
            log = os.path.join(logs, b"task-0.jsonl")
            r = subprocess.run([os.fsencode(CLI), b"--batch", jobs, b"--log", log], capture_output=True)
            self.assertEqual(r.returncode, 1, r.stderr)
            with open(log, "rb") as f:
                text = f.read().decode("utf-8")  # valid UTF-8
            first, second = [json.loads(line) for line in text.splitlines()]
            self.assertEqual(os.fsencode(first["inputs"][0]), name)
            self.assertEqual(os.fsencode(first["outputs"][0]), out)
            self.assertEqual(first["status"], "ok")
            self.assertIn(b"missing\xff.png", os.fsencode(second["message"]))
            slurm = os.path.join(os.path.dirname(CLI), "relief-slurm")
            s = subprocess.run([slurm, "status", jobs, "--log-dir", logs], capture_output=True)
            self.assertEqual(s.returncode, 1, s.stderr)
            self.assertEqual(s.stderr, b"")
            self.assertIn(b"2 job(s): 1 ok, 0 skipped, 1 failed, 0 missing", s.stdout.splitlines()[-1])
            self.assertIn(b"missing\xff.png", s.stdout)  # printed as the name's own bytes


class OpenImageIOInput(unittest.TestCase):
    """OpenImageIO's own Python images, and the float data it makes."""

    def test_an_imagebuf_is_read_as_its_file(self):
        buf = oiio.ImageBuf(NORMAL)
        from_buf = relief.height(buf, normal="opengl")
        from_file = relief.height(relief.read(NORMAL), normal="opengl")
        self.assertTrue(np.array_equal(from_buf, from_file))
        self.assertEqual(from_buf.metadata, from_file.metadata)
        with self.assertRaises(ValueError):
            relief.height(oiio.ImageBuf(os.path.join(DATA, "no such file.png")))

    def test_metadata_values_keep_their_types(self):
        h = relief.height(relief.read(NORMAL), normal="opengl")
        self.assertIsInstance(h.metadata["relief:invalid_normals"], int)
        self.assertIsInstance(h.metadata["relief:method"], str)
        offsets = relief.correct(h, scale=0.05, levels=1, iterations=2)
        self.assertIsInstance(offsets.metadata["relief:scale"], float)
        self.assertAlmostEqual(offsets.metadata["relief:scale"], 0.05, places=6)
        # typed values go back in: bake's wrap=auto reads the boundary
        heard = []
        relief.bake(relief.read(NORMAL), offsets, messages=lambda s, t: heard.append(t))
        self.assertTrue(any("clamp" in t or "wrapping" in t for t in heard), heard)

    def test_float_data_in_0_1_warns_to_use_range_unsigned(self):
        as_float = oiio.ImageBuf(NORMAL).get_pixels(oiio.FLOAT)  # [0, 1], as OpenImageIO reads 8 bit
        self.assertEqual(as_float.dtype, np.float32)
        truth = relief.height(relief.read(NORMAL), normal="opengl")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            wrong = relief.height(as_float, normal="opengl")
            right = relief.height(as_float, normal="opengl", range="unsigned")
        self.assertEqual(len(caught), 1)
        self.assertIs(caught[0].category, relief.ReliefWarning)
        self.assertIn("decode it with range=unsigned", str(caught[0].message))
        self.assertGreater(np.abs(wrong - truth).max(), 10.0)  # texels
        self.assertLess(np.abs(right - truth).max(), 0.05)


class Threads(unittest.TestCase):
    def test_the_gil_is_released_during_device_work(self):
        n = np.full((1024, 1024, 3), 128, np.uint8)
        n[..., 2] = 255
        n[::7, :, 0] = 150
        kw = {"normal": "opengl", "rays": 32, "radius": 64}
        relief.height(n, **kw)  # builds the kernels
        start = time.perf_counter()
        relief.height(n, **kw)
        alone = time.perf_counter() - start
        t = threading.Thread(target=relief.height, args=(n,), kwargs=kw)
        longest = 0.0
        last = time.perf_counter()
        t.start()
        while t.is_alive():  # this thread needs the GIL for every turn
            now = time.perf_counter()
            longest = max(longest, now - last)
            last = now
        t.join()
        # Holding the GIL through the device work would stall this loop for
        # about the whole call; released, it never waits more than a few
        # switch intervals.
        self.assertLess(longest, 0.5 * alone, f"the loop stalled {longest:.3f} s of a {alone:.3f} s call")

    def test_prepare_beside_a_height_changes_nothing(self):
        n = np.full((40, 52, 3), 128, np.uint8)
        n[..., 2] = 255
        n[::5, :, 0] = 160
        base = relief.height(n, normal="opengl", boundary="free")
        t = threading.Thread(target=relief.prepare, args=(52, 40))
        t.start()
        np.testing.assert_array_equal(relief.height(n, normal="opengl", boundary="free"), base)
        t.join()
        self.assertIsNone(relief.prepare(52, 40, device="9:9"))  # left for the operation to raise

if __name__ == "__main__":
    unittest.main()
