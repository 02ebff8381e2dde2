# SPDX-License-Identifier: Apache-2.0
"""scripts/corpus's judgement of a normal map and its height, on pairs made
here: the green convention and an upside-down height found, pairs that do
not belong together and maps that are not tangent-space refused, tiling per
axis measured, a licence found in a DEP-5 copyright by the file's path.
Run by ctest (python_corpus) with /usr/bin/python3."""
import importlib.machinery
import importlib.util
import os
import sys
import unittest

import numpy as np

sys.dont_write_bytecode = True  # (no __pycache__ beside scripts/corpus)

HERE = os.path.dirname(os.path.abspath(__file__))
_loader = importlib.machinery.SourceFileLoader("corpus", os.path.join(HERE, "..", "..", "scripts", "corpus"))
_spec = importlib.util.spec_from_loader("corpus", _loader)
corpus = importlib.util.module_from_spec(_spec)
_loader.exec_module(corpus)


def field(w, h, periodic_y=True, seed=3):
    """A height in [0, 1], periodic along x (and y unless told)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    out = np.zeros((h, w))
    for _ in range(12):
        kx, ky = rng.integers(1, 6), rng.integers(1, 6)
        fy = ky / h if periodic_y else (ky + 0.37) / h  # not whole cycles: a seam along y
        out += rng.normal() * np.sin(2 * np.pi * (kx * x / w + fy * y) + rng.uniform(0, 6.3)) / (kx + ky)
    return (out - out.min()) / (out.max() - out.min())


def normals(h, k=20.0, green=+1):
    """8-bit normals of h: n = normalize(-k dh/dx, green * k dh/drow, 1),
    differences wrapping."""
    hx = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / 2
    hr = (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / 2
    n = np.stack([-k * hx, green * k * hr, np.ones_like(h)], axis=2)
    n /= np.sqrt((n * n).sum(axis=2))[:, :, None]
    return np.round((n * 0.5 + 0.5) * 255) / 255


class Judgement(unittest.TestCase):
    def test_convention_and_scale(self):
        h = field(128, 96)
        for green, name in ((+1, "Y+ (OpenGL)"), (-1, "Y- (DirectX)")):
            m, kept = corpus.analyse(normals(h, green=green), h)
            self.assertIsNotNone(m, kept)
            self.assertEqual(m["green"], name)
            self.assertFalse(m["height_inverted"])
            self.assertGreater(m["corr_R_vs_minus_dhdx"], 0.95)
            self.assertAlmostEqual(m["fit_scale_px_per_unit_height"], 20.0, delta=2.0)
            self.assertLess(m["mean_angular_error_deg"], 2.0)
            self.assertEqual((m["width"], m["height"]), (128, 96))

    def test_upside_down_height_is_turned(self):
        h = field(128, 96)
        m, kept = corpus.analyse(normals(h), 1.0 - h)
        self.assertTrue(m["height_inverted"])
        self.assertEqual(m["green"], "Y+ (OpenGL)")
        np.testing.assert_allclose(kept, h)

    def test_strangers_and_non_tangent_maps_refused(self):
        h, other = field(128, 96, seed=3), field(128, 96, seed=4)
        m, why = corpus.analyse(normals(h), other)
        self.assertIsNone(m)
        self.assertIn("disagree", why)
        n = normals(h)
        n[:, :, 2] = 1.0 - n[:, :, 2]  # z pointing down: an object-space map's back
        self.assertIsNone(corpus.analyse(n, h)[0])
        self.assertIn("flat height", corpus.analyse(normals(h), np.full_like(h, 0.5))[1])
        self.assertIn("smaller", corpus.analyse(normals(h[:40, :40]), h[:40, :40])[1])

    def test_tiling_per_axis(self):
        m, _ = corpus.analyse(*(lambda h: (normals(h), h))(field(128, 96, periodic_y=True)))
        self.assertEqual(m["tiling_per_axis"], ["yes", "yes"])
        m, _ = corpus.analyse(*(lambda h: (normals(h), h))(field(128, 96, periodic_y=False)))
        self.assertEqual(m["tiling_per_axis"], ["yes", "no"])

    def test_names_and_licences(self):
        for stem in ("brick2_nm", "wall_norm", "metal_tech_01_normal", "rock-local", "stone_n"):
            self.assertTrue(corpus.NORMAL_SUFFIX.match(stem), stem)
        self.assertEqual(corpus.NORMAL_SUFFIX.match("brick2_nm").group("base"), "brick2")
        for stem in ("normalize", "brick2", "sign"):
            self.assertFalse(corpus.NORMAL_SUFFIX.match(stem), stem)
        stanzas = [(["*"], "GPL-2+", "the authors"), (["data/trak/*"], "CC-BY-3.0", "TRaK"),
                   (["data/trak/trak4/sky*"], "CC0", "someone")]
        lic = corpus.licence_of(stanzas, "usr/share/games/redeclipse/data/trak/trak4/brick2_nm.png")
        self.assertEqual(lic[:2], ("CC-BY-3.0", "TRaK"))
        self.assertEqual(corpus.licence_of(stanzas, "usr/share/games/redeclipse/data/other/x.png")[0], "GPL-2+")
        self.assertEqual(corpus.kind_of("data/trak/trak4/brick2_nm.png"), "bricks")
        self.assertEqual(corpus.kind_of("textures/terrain/sand01_norm.tga"), "terrain")


if __name__ == "__main__":
    unittest.main()
