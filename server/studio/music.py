"""Music for the timeline: a WAV file's tempo and beats (to show as a grid and snap to).

Onset strength is the positive change of short-time energy (23 ms hops); the tempo is the beat period (60 to 180
beats per minute) whose comb of onsets correlates best with it, and the beats are that comb at the phase that
collects the most onset strength. Enough for music with a steady pulse; the studio lets the user correct tempo and
offset by hand.
"""

from __future__ import annotations

import io
import wave
from dataclasses import dataclass

import numpy as np

HOP_S = 0.0116  # onset-envelope step, s
MIN_BPM, MAX_BPM = 60.0, 180.0
MAX_AUDIO_S = 600.0  # longer files are cut (ten minutes of music is more than a maneuver's 60 s)


class AudioError(ValueError):
    """The file is not a WAV file this reader understands (PCM, 8/16/32-bit)."""


@dataclass(frozen=True)
class Beats:
    """A steady pulse: tempo (beats per minute), the first beat's time (s) and the song's length (s)."""

    bpm: float
    offset_s: float
    duration_s: float

    def times(self, until_s: float | None = None) -> list[float]:
        """Returns the beat times (s) from the offset to `until_s` (default: the song's end)."""
        end = self.duration_s if until_s is None else until_s
        period = 60.0 / self.bpm
        n = int(np.floor((end - self.offset_s) / period)) + 1 if end >= self.offset_s else 0
        return [round(self.offset_s + k * period, 4) for k in range(max(n, 0))]

    def snap(self, t: float) -> float:
        """Returns the beat nearest to t (s)."""
        period = 60.0 / self.bpm
        k = max(0, round((t - self.offset_s) / period))
        return round(self.offset_s + k * period, 4)


def read_wav(data: bytes) -> tuple[np.ndarray, int]:
    """Returns (mono samples in [-1, 1], sample rate) of a PCM WAV file's bytes."""
    try:
        with wave.open(io.BytesIO(data)) as w:
            rate, width, channels = w.getframerate(), w.getsampwidth(), w.getnchannels()
            raw = w.readframes(min(w.getnframes(), int(MAX_AUDIO_S * rate)))
    except (wave.Error, EOFError) as e:
        raise AudioError(f"not a PCM WAV file: {e}") from None
    kinds = {1: (np.uint8, 128.0, 128.0), 2: (np.int16, 0.0, 32768.0), 4: (np.int32, 0.0, 2147483648.0)}
    if width not in kinds:
        raise AudioError(f"{8 * width}-bit samples are not supported (8, 16 or 32-bit PCM)")
    dtype, zero, scale = kinds[width]
    x = (np.frombuffer(raw, dtype=dtype).astype(float) - zero) / scale
    x = x[: len(x) - len(x) % channels].reshape(-1, channels).mean(axis=1)
    if len(x) < rate:
        raise AudioError("shorter than a second: no tempo to find")
    return x, rate


PLAY_RATE_HZ = 22050  # the copy of the music the tab plays: mono, 16-bit, at most this rate
PLAY_MAX_S = 75.0  # ... and this long (a maneuver lasts at most 60 s)


def playable_wav(x: np.ndarray, rate: int) -> bytes:
    """Returns a small WAV file (mono, 16-bit, ≤ PLAY_RATE_HZ, ≤ PLAY_MAX_S) of mono samples x at `rate` Hz, for the
    tab to play beside the preview: block averages as the (crude) low-pass before dropping samples."""
    k = max(1, int(np.ceil(rate / PLAY_RATE_HZ)))
    x = np.asarray(x[: int(PLAY_MAX_S * rate)], dtype=float)
    n = len(x) // k
    y = x[: n * k].reshape(n, k).mean(axis=1) if k > 1 else x
    pcm = (np.clip(y, -1.0, 1.0) * 32767.0).astype("<i2")
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(int(round(rate / k)))
        w.writeframes(pcm.tobytes())
    return buf.getvalue()


def audio_html(wav: bytes) -> str:
    """Returns the tab's audio element for a WAV file's bytes (page.js starts, seeks and pauses it with the
    preview)."""
    import base64

    src = "data:audio/wav;base64," + base64.b64encode(wav).decode("ascii")
    return (f'<audio data-footfall-audio="1" controls preload="auto" src="{src}" '
            'style="width: 100%; height: 28px"></audio>')  # fmt: skip


def clock_html(t: float, playing: bool, rate: float, run: str) -> str:
    """Returns the hidden element that tells page.js where the preview is: its time (s), whether it plays, at what
    speed, and which run (a new run restarts the music)."""
    import html as _html

    return (f'<span data-footfall-clock="1" data-t="{t:.3f}" data-playing="{1 if playing else 0}" '
            f'data-rate="{rate:.3f}" data-run="{_html.escape(run)}" style="display: none"></span>')  # fmt: skip


def find_beats(x: np.ndarray, rate: int) -> Beats:
    """Returns the tempo and beat phase of mono samples x at `rate` Hz."""
    hop = max(1, int(HOP_S * rate))
    n = len(x) // hop
    energy = np.sqrt(np.mean(x[: n * hop].reshape(n, hop) ** 2, axis=1))
    onset = np.maximum(np.diff(energy, prepend=energy[0]), 0.0)
    onset -= onset.mean()
    dt = hop / rate
    best: tuple[float, float] = (-np.inf, 120.0)
    for bpm in np.arange(MIN_BPM, MAX_BPM + 0.01, 0.5):
        lag = 60.0 / bpm / dt
        # the comb's correlation at integer multiples of the lag (4 beats), interpolated between samples
        score = 0.0
        for m in (1, 2, 3, 4):
            k = m * lag
            k0 = int(k)
            if k0 + 1 >= len(onset):
                break
            w = k - k0
            score += float(np.dot(onset[: -k0 - 1], (1 - w) * onset[k0:-1] + w * onset[k0 + 1 :]))
        if score > best[0]:
            best = (score, float(bpm))
    bpm = best[1]
    period = 60.0 / bpm
    pos = np.maximum(onset, 0.0)
    t = np.arange(len(pos)) * dt
    phases = np.arange(0.0, period, dt)
    sums = [float(pos[np.clip(np.round((np.arange(ph, t[-1], period)) / dt).astype(int), 0, len(pos) - 1)].sum())
            for ph in phases]  # fmt: skip
    offset = float(phases[int(np.argmax(sums))])
    # the first beat is the first of the comb the music plays (silence or an intro before it is not a beat)
    comb = np.arange(offset, t[-1], period)
    idx = np.clip(np.round(comb / dt).astype(int), 0, len(pos) - 1)
    strength = np.array([pos[max(0, i - 2) : i + 3].max() for i in idx])
    if len(strength):
        first = int(np.argmax(strength >= 0.3 * float(np.median(strength))))
        offset = float(comb[first])
    return Beats(bpm, round(offset, 4), round(len(x) / rate, 3))
