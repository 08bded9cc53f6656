"""An asynchronous serial line (RS-232): its settings, a byte's time on it, and what a
receiver set otherwise makes of it.

A UART frames each byte as one start bit (0), the data bits least significant first, an
optional parity bit and one or two stop bits (1); the line idles at 1 (TIA-232 / any UART
datasheet, e.g. the 16550's). The receiver finds the start bit's falling edge and samples
every following bit in its middle at its own baud rate, so a sender and a receiver that
disagree on the rate, the data bits or the stop bits see different bytes: `received` is
that sampling, done bit by bit on the sender's waveform. Assumed (not in a manual): the
receiver checks every stop bit it is set for, and a frame whose stop bit reads 0 or whose
parity is wrong arrives as NUL, as Linux's termios delivers it without IGNPAR or PARMRK
(termios(3), "INPCK").

The settings each instrument's manual gives for its port are in `MANUAL_SETTINGS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

PARITIES = ("N", "E", "O")


@dataclass(frozen=True)
class LineSettings:
    """Baud rate, data bits, parity (N, E, O) and stop bits of one end of a line."""

    baud: int
    data_bits: int = 8
    parity: str = "N"
    stop_bits: int = 1

    def __post_init__(self) -> None:
        if self.baud <= 0 or self.data_bits not in (5, 6, 7, 8) or self.parity not in PARITIES \
                or self.stop_bits not in (1, 2):
            raise ValueError(f"not a serial line setting: {self}")

    @property
    def frame_bits(self) -> int:
        """Bits on the line per byte: start + data + parity + stop."""
        return 1 + self.data_bits + (self.parity != "N") + self.stop_bits

    def transfer_s(self, n_bytes: int) -> float:
        """Time `n_bytes` take back to back on the line: n * frame bits / baud."""
        return n_bytes * self.frame_bits / self.baud

    def __str__(self) -> str:
        return f"{self.baud} baud {self.data_bits}{self.parity}{self.stop_bits}"


#: Each serial instrument's port as its manual gives it. 33120A: User's Guide, Chapter 3
#: "RS-232 interface configuration" (factory 9600 baud, 8 data bits no parity, 2 stop bits
#: fixed; DTR/DSR handshake). OFV-5000: user manual, RS-232 interface (115200 baud 8N1).
#: SMC100: user's manual, "Communication" (57600 baud 8N1, XON/XOFF).
MANUAL_SETTINGS = {
    "generator": LineSettings(9600, 8, "N", 2),
    "vibrometer": LineSettings(115200, 8, "N", 1),
    "stage": LineSettings(57600, 8, "N", 1),
}


def _parity_bit(value: int, parity: str) -> int:
    ones = bin(value).count("1")
    return ones % 2 if parity == "E" else 1 - ones % 2


def frame(value: int, settings: LineSettings) -> list[int]:
    """One byte's bits on the line, start bit first."""
    value &= (1 << settings.data_bits) - 1
    bits = [0] + [(value >> i) & 1 for i in range(settings.data_bits)]
    if settings.parity != "N":
        bits.append(_parity_bit(value, settings.parity))
    return bits + [1] * settings.stop_bits


def received(data: bytes, sent_with: LineSettings, read_with: LineSettings) -> bytes:
    """What a receiver set to `read_with` reads of `data` sent back to back with `sent_with`."""
    if sent_with == read_with:
        return bytes(data)
    bits = [bit for value in data for bit in frame(value, sent_with)]
    sent_bit_s, read_bit_s = 1.0 / sent_with.baud, 1.0 / read_with.baud

    def level(time_s: float) -> int:
        index = math.floor(time_s / sent_bit_s + 1e-9)
        return bits[index] if 0 <= index < len(bits) else 1

    out = bytearray()
    t, end_s = 0.0, len(bits) * sent_bit_s
    n_read = read_with.frame_bits - 1   # bits after the start bit
    while t < end_s:
        index = math.floor(t / sent_bit_s + 1e-9)
        while index < len(bits) and bits[index] == 1:   # idle: wait for a start bit's edge
            index += 1
        if index >= len(bits):
            break
        start_s = max(t, index * sent_bit_s)
        samples = [level(start_s + (k + 1.5) * read_bit_s) for k in range(n_read)]
        value = sum(bit << i for i, bit in enumerate(samples[:read_with.data_bits]))
        rest = samples[read_with.data_bits:]
        parity_ok = read_with.parity == "N" or rest.pop(0) == _parity_bit(value, read_with.parity)
        out.append(value if parity_ok and all(rest) else 0)
        t = start_s + (read_with.frame_bits - 0.5) * read_bit_s   # the last stop bit's middle
    return bytes(out)
