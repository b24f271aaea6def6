"""Every musical preset's reference phrase (issue 12): what
``tools/calibrate_levels.py`` renders to set each preset's output gain, and
writes as ``synth/presets/checks/phrases/<preset>.mid``, the phrase the
shipped check specs hold at -20 LUFS (``synth check --shipped``).

* :func:`musical_presets`: the presets calibrated (every musical one);
* :func:`phrase_events`: a preset's phrase, (on, off, key, velocity) notes;
* :func:`write_midi`: the phrase as a MIDI file.
"""

from __future__ import annotations

from pathlib import Path


TARGET_LUFS = -20.0


#: scale steps of the melody (a major pentatonic over 1.5 octaves, up and down)
MELODY = (0, 2, 4, 7, 9, 12, 14, 12, 9, 7, 4, 0)


NOTE_S = 0.35


VELOCITY = 100


#: length of the rendered phrase (s): the 12 notes and the last one's ring
PHRASE_SECONDS = 5.7


def musical_presets(folder=None) -> list[str]:
    """The musical presets (``kind = "musical"``) of ``folder`` (default: the
    shipped presets), by name."""
    from ..io.presets import load_preset, shipped_preset_dir

    folder = Path(shipped_preset_dir() if folder is None else folder)
    out = []
    for p in sorted(folder.glob("*.toml")):
        if load_preset(str(p)).kind == "musical":
            out.append(p.stem)
    return out


def phrase_events(preset) -> list[tuple[float, float, int, int]]:
    """The reference phrase of a preset: (on_s, off_s, key, velocity) tuples.
    The melody starts where 1.5 octaves fit in the playable range (centred,
    at most from key 60); keyboards (grand, harpsichord) add a dyad an
    octave and a fifth below the melody's first note under each group of
    four notes.  A drone preset (``[drone]`` with its player on) plays its
    drone instead: one key at the lowest Sa of its range starts the cycle."""
    lo, hi = preset.play.key_low, preset.play.key_high
    drone = getattr(preset, "drone", None)
    if drone is not None and drone.player == "on":
        # a drone preset's keys start its player: the phrase is the drone
        # itself, from the lowest Sa whose low Sa the range holds
        return [(0.0, 0.5, min(lo + 12, hi), VELOCITY)]
    span = max(MELODY)
    base = min(60, lo + max(0, (hi - lo - span) // 2))
    ev = []
    t = 0.0
    for i, step in enumerate(MELODY):
        last = i == len(MELODY) - 1
        ev.append((t, t + (1.5 if last else NOTE_S * 0.9), base + step, VELOCITY))
        t += NOTE_S
    if preset.voice in ("grand", "harpsichord"):
        for g in range(0, len(MELODY), 4):
            t0 = g * NOTE_S
            for k in (base - 12, base - 5):
                if lo <= k <= hi:
                    ev.append((t0, t0 + 4 * NOTE_S * 0.95, k, VELOCITY - 20))
    return sorted(ev)


def write_midi(events, path: Path) -> None:
    import mido

    tpb, tempo = 480, 500_000           # 120 bpm: 960 ticks per second
    msgs = []
    for on, off, key, vel in events:
        msgs.append((on, mido.Message("note_on", note=key, velocity=vel)))
        msgs.append((off, mido.Message("note_off", note=key, velocity=64)))
    msgs.sort(key=lambda m: (m[0], m[1].type == "note_on"))
    mf = mido.MidiFile(ticks_per_beat=tpb)
    tr = mido.MidiTrack()
    mf.tracks.append(tr)
    tr.append(mido.MetaMessage("set_tempo", tempo=tempo, time=0))
    now = 0
    for t, m in msgs:
        tick = int(round(t * 1e6 / tempo * tpb))
        tr.append(m.copy(time=tick - now))
        now = tick
    path.parent.mkdir(parents=True, exist_ok=True)
    mf.save(str(path))
