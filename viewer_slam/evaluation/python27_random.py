"""Python 2.7's ``random`` module, reproduced draw for draw.

TUM's ``evaluate_rpe.py`` picks its pose pairs with ``random.randint`` after
``random.seed(0)``, and the studies that published its figures ran it under Python 2.7.
Python 3 keeps the same Mersenne Twister and the same seeding of integers, but draws
integers differently (``randrange`` uses rejection sampling on ``getrandbits`` where 2.7
took ``int(random() * n)``), so the same script under Python 3 scores other pairs and
prints other figures. Replaying a published figure needs 2.7's integer draws; this module
is MT19937 as CPython's ``_randommodule.c`` implements it (``init_by_array`` of the seed's
32-bit words, 53-bit ``random()``) under 2.7's ``Lib/random.py`` methods.

Pure Python with no dependency: a few thousand draws take milliseconds.
"""

import math
from collections.abc import Sequence
from typing import Any, TypeVar

Item = TypeVar("Item")

_N = 624
_M = 397
_MATRIX_A = 0x9908B0DF
_UPPER_MASK = 0x80000000
_LOWER_MASK = 0x7FFFFFFF
_WORD = 0xFFFFFFFF
BPF = 53  # bits in a float's mantissa: 2.7's ``randrange`` switches to ``_randbelow`` at 2**53


class Python27Random:
    """A ``random.Random`` of Python 2.7: same seed, same sequence of ``random()``, ``randint``,
    ``randrange``, ``choice``, ``sample``, ``shuffle`` and ``getrandbits`` results."""

    def __init__(self, seed: int = 0):
        self.seed(seed)

    # -- the generator (_randommodule.c) ------------------------------------------------

    def seed(self, seed: int) -> None:
        """2.7's ``random.seed(n)`` for an integer: ``init_by_array`` of |n| split into 32-bit
        words from the least significant one (``[0]`` for zero)."""
        if not isinstance(seed, int):
            raise TypeError(f"only integer seeds are reproduced (2.7 hashes other objects), got {type(seed).__name__}")
        n = abs(seed)
        key = []
        while n:
            key.append(n & _WORD)
            n >>= 32
        self._init_by_array(key or [0])

    def _init_genrand(self, s: int) -> None:
        mt = [0] * _N
        mt[0] = s & _WORD
        for i in range(1, _N):
            mt[i] = (1812433253 * (mt[i - 1] ^ (mt[i - 1] >> 30)) + i) & _WORD
        self._mt = mt
        self._index = _N

    def _init_by_array(self, key: list[int]) -> None:
        self._init_genrand(19650218)
        mt = self._mt
        i, j = 1, 0
        for _ in range(max(_N, len(key))):
            mt[i] = ((mt[i] ^ ((mt[i - 1] ^ (mt[i - 1] >> 30)) * 1664525)) + key[j] + j) & _WORD
            i += 1
            j += 1
            if i >= _N:
                mt[0] = mt[_N - 1]
                i = 1
            if j >= len(key):
                j = 0
        for _ in range(_N - 1):
            mt[i] = ((mt[i] ^ ((mt[i - 1] ^ (mt[i - 1] >> 30)) * 1566083941)) - i) & _WORD
            i += 1
            if i >= _N:
                mt[0] = mt[_N - 1]
                i = 1
        mt[0] = 0x80000000  # MSB is 1, assuring a non-zero initial array
        self._index = _N

    def _twist(self) -> None:
        mt = self._mt
        for k in range(_N):
            y = (mt[k] & _UPPER_MASK) | (mt[(k + 1) % _N] & _LOWER_MASK)
            mt[k] = mt[(k + _M) % _N] ^ (y >> 1) ^ (_MATRIX_A if y & 1 else 0)
        self._index = 0

    def genrand_int32(self) -> int:
        """The next tempered 32-bit word."""
        if self._index >= _N:
            self._twist()
        y = self._mt[self._index]
        self._index += 1
        y ^= y >> 11
        y ^= (y << 7) & 0x9D2C5680
        y ^= (y << 15) & 0xEFC60000
        return y ^ (y >> 18)

    def random(self) -> float:
        """A float in [0, 1) with 53 random bits: ``(a * 2**26 + b) / 2**53`` from two words."""
        a = self.genrand_int32() >> 5
        b = self.genrand_int32() >> 6
        return (a * 67108864.0 + b) * (1.0 / 9007199254740992.0)

    def getrandbits(self, k: int) -> int:
        """``k`` random bits: whole words from the least significant end, the last one's top bits."""
        if k <= 0:
            raise ValueError("number of bits must be greater than zero")
        if k <= 32:
            return self.genrand_int32() >> (32 - k)
        value, shift = 0, 0
        while k > 0:
            word = self.genrand_int32()
            if k < 32:
                word >>= 32 - k
            value |= word << shift
            shift += 32
            k -= 32
        return value

    # -- Lib/random.py of 2.7 ------------------------------------------------------------

    def _randbelow(self, n: int) -> int:
        """2.7's ``_randbelow`` (used only for ranges of 2**53 and more)."""
        k = int(1.00001 + math.log(n - 1, 2.0))
        r = self.getrandbits(k)
        while r >= n:
            r = self.getrandbits(k)
        return r

    def randrange(self, start: int, stop: int | None = None, step: int = 1) -> int:
        """2.7's ``randrange``: ``start + int(random() * width)`` below 2**53 values."""
        if stop is None:
            if start > 0:
                return self._randbelow(start) if start >= 1 << BPF else int(self.random() * start)
            raise ValueError("empty range for randrange()")
        width = stop - start
        if step == 1:
            if width <= 0:
                raise ValueError(f"empty range for randrange() ({start},{stop}, {width})")
            return start + (self._randbelow(width) if width >= 1 << BPF else int(self.random() * width))
        if step == 0:
            raise ValueError("zero step for randrange()")
        n = (width + step - 1) // step if step > 0 else (width + step + 1) // step
        if n <= 0:
            raise ValueError("empty range for randrange()")
        return start + step * (self._randbelow(n) if n >= 1 << BPF else int(self.random() * n))

    def randint(self, a: int, b: int) -> int:
        """An integer in [a, b], both ends included."""
        return self.randrange(a, b + 1)

    def choice(self, seq: Sequence[Item]) -> Item:
        """``seq[int(random() * len(seq))]``."""
        return seq[int(self.random() * len(seq))]

    def shuffle(self, x: list[Any]) -> None:
        """2.7's in-place shuffle: ``j = int(random() * (i + 1))`` from the end."""
        for i in reversed(range(1, len(x))):
            j = int(self.random() * (i + 1))
            x[i], x[j] = x[j], x[i]

    def sample(self, population: Sequence[Item], k: int) -> list[Item]:
        """2.7's ``sample``: a pool for small populations, else redraws against a set of picks."""
        n = len(population)
        if not 0 <= k <= n:
            raise ValueError("sample larger than population")
        result: list[Any] = [None] * k
        setsize = 21
        if k > 5:
            setsize += 4 ** math.ceil(math.log(k * 3, 4))
        if n <= setsize or hasattr(population, "keys"):
            pool = list(population)
            for i in range(k):
                j = int(self.random() * (n - i))
                result[i] = pool[j]
                pool[j] = pool[n - i - 1]
        else:
            selected: set[int] = set()
            for i in range(k):
                j = int(self.random() * n)
                while j in selected:
                    j = int(self.random() * n)
                selected.add(j)
                result[i] = population[j]
        return result
