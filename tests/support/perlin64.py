"""An independent double-precision (numpy float64) transcription of Ken Perlin's
improved-noise reference code (2002) and of the tutorial's version of it, and the
tutorial's turbulence and marble (facts.md F7), for checking the plugins. It follows the code
line by line (14 table look-ups, the branchy ``grad``) and shares no code with
``codermind``.

``gradient`` chooses the ``grad`` function (facts.md F9): ``"tutorial"`` (the tutorial's
printed code: u = x if h < 8 or h is 12 or 13, else y; v = y if h < 4 or h is 12 or 13,
else z) or ``"reference"`` (Perlin's: v = y if h < 4, x if h is 12 or 14, else z).
Every function here defaults to the tutorial's, as the plugins do."""

from __future__ import annotations

import numpy as np

# Ken Perlin's table, as printed in his reference implementation.
_P = np.array([int(v) for v in """
151 160 137 91 90 15 131 13 201 95 96 53 194 233 7 225 140 36 103 30 69 142 8 99 37 240 21
10 23 190 6 148 247 120 234 75 0 26 197 62 94 252 219 203 117 35 11 32 57 177 33 88 237 149
56 87 174 20 125 136 171 168 68 175 74 165 71 134 139 48 27 166 77 146 158 231 83 111 229
122 60 211 133 230 220 105 92 41 55 46 245 40 244 102 143 54 65 25 63 161 1 216 80 73 209
76 132 187 208 89 18 169 200 196 135 130 116 188 159 86 164 100 109 198 173 186 3 64 52 217
226 250 124 123 5 202 38 147 118 126 255 82 85 212 207 206 59 227 47 16 58 17 182 189 28 42
223 183 170 213 119 248 152 2 44 154 163 70 221 153 101 155 167 43 172 9 129 22 39 253 19 98
108 110 79 113 224 232 178 185 112 104 218 246 97 228 251 34 242 193 238 210 144 12 191 179
162 241 81 51 145 235 249 14 239 107 49 192 214 31 181 199 106 157 184 84 204 176 115 121 50
45 127 4 150 254 138 236 205 93 222 114 67 29 24 72 243 141 128 195 78 66 215 61 156 180
""".split()] * 2, dtype=np.int64)


def _fade(t):
    return t * t * t * (t * (t * 6 - 15) + 10)


def _lerp(t, a, b):
    return a + t * (b - a)


def _grad_reference(hash_, x, y, z):
    h = hash_ & 15
    u = np.where(h < 8, x, y)
    v = np.where(h < 4, y, np.where((h == 12) | (h == 14), x, z))
    return np.where(h & 1 == 0, u, -u) + np.where(h & 2 == 0, v, -v)


def _grad_tutorial(hash_, x, y, z):
    h = hash_ & 15
    twelve = (h == 12) | (h == 13)
    u = np.where((h < 8) | twelve, x, y)
    v = np.where((h < 4) | twelve, y, z)
    return np.where(h & 1 == 0, u, -u) + np.where(h & 2 == 0, v, -v)


_GRADS = {"tutorial": _grad_tutorial, "reference": _grad_reference}


def noise(x, y, z, gradient="tutorial"):
    """noise(x, y, z) in float64 for arrays of coordinates, with the chosen gradient."""
    _grad = _GRADS[gradient]
    x, y, z = (np.asarray(c, dtype=np.float64) for c in (x, y, z))
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    X, Y, Z = (f.astype(np.int64) & 255 for f in (fx, fy, fz))
    x, y, z = x - fx, y - fy, z - fz
    u, v, w = _fade(x), _fade(y), _fade(z)
    p = _P
    A = p[X] + Y
    AA = p[A] + Z
    AB = p[A + 1] + Z
    B = p[X + 1] + Y
    BA = p[B] + Z
    BB = p[B + 1] + Z
    return _lerp(w, _lerp(v, _lerp(u, _grad(p[AA], x, y, z), _grad(p[BA], x - 1, y, z)),
                          _lerp(u, _grad(p[AB], x, y - 1, z), _grad(p[BB], x - 1, y - 1, z))),
                 _lerp(v, _lerp(u, _grad(p[AA + 1], x, y, z - 1), _grad(p[BA + 1], x - 1, y, z - 1)),
                       _lerp(u, _grad(p[AB + 1], x, y - 1, z - 1),
                             _grad(p[BB + 1], x - 1, y - 1, z - 1))))


def turbulence(p, frequency=0.05, octaves=9, gradient="tutorial"):
    """T = sum_k |noise(frequency k p)| / k, p of shape (3, n)."""
    p = np.asarray(p, dtype=np.float64)
    return sum(np.abs(noise(*(frequency * k * p), gradient)) / k
               for k in range(1, octaves + 1))


def marble(p, frequency=0.05, octaves=9, stripe=0.05, gradient="tutorial"):
    """m = 0.5 sin(stripe (x + y) + T) + 0.5."""
    p = np.asarray(p, dtype=np.float64)
    t = turbulence(p, frequency, octaves, gradient)
    return 0.5 * np.sin(stripe * (p[0] + p[1]) + t) + 0.5


def bump_vector(p, frequency=0.1, gradient="tutorial"):
    """The tutorial's bump perturbation (noise(f(x,y,z)), noise(f(y,z,x)), noise(f(z,x,y)))."""
    x, y, z = np.asarray(p, dtype=np.float64) * frequency
    return np.stack([noise(x, y, z, gradient), noise(y, z, x, gradient),
                     noise(z, x, y, gradient)])
