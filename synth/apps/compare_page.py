"""The page of ``synth compare``: one self-contained HTML file.

:func:`render_page` fills :data:`TEMPLATE` with the comparison's data
(JSON, in a ``<script type="application/json">``) and the audio (base64 of
the WAV files, one ``<script type="application/octet-stream">`` each).  No
script, style, font or image is fetched: the page works from ``file://``
with no network.  The script:

* decodes every WAV with an ``OfflineAudioContext`` at the data's rate
  (no resampling) when the page loads; the playing ``AudioContext`` is made
  on the first click (browsers start audio only after a gesture);
* plays every buffer at once, in lockstep from one start time and offset,
  each through its own gain: switching stimulus moves the gains (3 ms
  time constant), so the playhead cannot move; the loop region is the
  sources' ``loopStart``/``loopEnd`` (changing it restarts them at the
  playhead);
* draws ABX's X from ``crypto.getRandomValues``, or from mulberry32 seeded
  by ``?seed=N`` (the tests replay it); p-values are exact (BigInt);
* exposes ``window.synthCompare`` for tests and scripts (state, CSV, JSON).
"""

from __future__ import annotations

import html
import json

__all__ = ["TEMPLATE", "render_page"]


def render_page(data: dict, audio_b64: dict[str, str]) -> str:
    """The page for ``data`` (JSON-ready, finite numbers) and the base64 WAV
    bytes of each buffer id."""
    audio = "\n".join(f'<script type="application/octet-stream" id="audio-{html.escape(i)}">'
                      f"{b}</script>" for i, b in audio_b64.items())
    title = f"synth compare: {len(data['stimuli'])} stimuli"
    js_data = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")
    page = TEMPLATE.replace("@@AUDIO@@", audio).replace("@@TITLE@@", html.escape(title))
    page = page.replace("@@MUSHRA_TOO@@", " and the MUSHRA ratings submitted" if data["mushra"] else "")
    return page.replace("@@DATA@@", js_data)


TEMPLATE = r"""<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<link rel="icon" href="data:,">
<title>@@TITLE@@</title>
<style>
:root { --fg: #1d1d1f; --muted: #666; --line: #d0d0d5; --accent: #2a5db0; --bg2: #f4f4f7;
        --good: #1c7c3a; --bad: #b3261e; }
* { box-sizing: border-box; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; color: var(--fg);
       max-width: 980px; margin: 0 auto; padding: 1rem 1.2rem 3rem; }
h1 { font-size: 1.4rem; margin: .2rem 0; }
h2 { font-size: 1.1rem; margin: 0 0 .5rem; }
section { border: 1px solid var(--line); border-radius: 8px; padding: .8rem 1rem; margin: .9rem 0; }
.row { display: flex; flex-wrap: wrap; gap: .45rem; align-items: center; margin: .35rem 0; }
button { font: inherit; padding: .3rem .8rem; border: 1px solid var(--line); border-radius: 6px;
         background: var(--bg2); cursor: pointer; min-width: 2.6rem; }
button:hover:not(:disabled) { border-color: var(--accent); }
button:disabled { opacity: .45; cursor: default; }
button.active { background: var(--accent); color: #fff; border-color: var(--accent); }
input[type=number] { width: 5.5rem; font: inherit; }
input[type=text] { font: inherit; width: 12rem; }
canvas { width: 100%; height: 48px; border: 1px solid var(--line); border-radius: 4px; cursor: pointer; }
.hint, .muted { color: var(--muted); font-size: .88rem; }
.notice { background: #fff4d6; border: 1px solid #e8c766; padding: .4rem .7rem; border-radius: 6px; }
.good { color: var(--good); } .bad { color: var(--bad); }
pre { background: var(--bg2); padding: .5rem; overflow-x: auto; font-size: .8rem; max-height: 14rem; }
table { border-collapse: collapse; margin: .4rem 0; font-size: .9rem; }
th, td { border-bottom: 1px solid var(--line); padding: .2rem .55rem; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
#mushra-items input[type=range] { width: 22rem; max-width: 60vw; }
.spectro figure { margin: .6rem 0; } .spectro img { max-width: 100%; border: 1px solid var(--line); }
.big { font-size: 1.15rem; font-weight: 600; }
</style>
</head>
<body>
<header>
  <h1>synth compare</h1>
  <p id="summary" class="muted"></p>
  <p id="notice" class="notice" hidden></p>
</header>

<section id="transport">
  <h2>Player</h2>
  <div class="row">
    <button id="play">Play</button>
    <button id="stop" disabled>Stop</button>
    <span>now: <b id="now-playing">A</b></span>
    <span id="time" class="muted">0.00 / 0.00 s</span>
    <span id="load-status" class="muted">decoding audio...</span>
  </div>
  <canvas id="timeline" width="900" height="48" title="click to move the playhead"></canvas>
  <div class="row">
    <span>loop</span>
    <label>from <input id="loop-start" type="number" step="0.01" min="0"> s</label>
    <label>to <input id="loop-end" type="number" step="0.01" min="0"> s</label>
    <button id="loop-set-start">from = playhead</button>
    <button id="loop-set-end">to = playhead</button>
    <button id="loop-all">whole</button>
  </div>
  <p class="hint">Every stimulus plays at once and in step; choosing one switches what you hear
  at the same playhead. Keys: space play/stop, 1-9 the stimuli, and in ABX a, b, x.</p>
</section>

<section id="ab">
  <h2>A/B</h2>
  <p class="hint">Listen and switch freely. The names stay hidden until the reveal.</p>
  <div id="ab-buttons" class="row"></div>
</section>

<section id="abx">
  <h2>ABX (blind)</h2>
  <p class="hint">X is A or B, drawn anew for each trial. Listen to A, B and X, then say which one X is.</p>
  <div class="row" id="abx-pair">
    <label>A = <select id="abx-a"></select></label>
    <label>B = <select id="abx-b"></select></label>
    <button id="abx-start">Start</button>
  </div>
  <div class="row">
    <button id="abx-play-a" disabled>A</button>
    <button id="abx-play-b" disabled>B</button>
    <button id="abx-play-x" disabled>X</button>
    <span style="width:1.5rem"></span>
    <button id="abx-answer-a" disabled>X is A</button>
    <button id="abx-answer-b" disabled>X is B</button>
  </div>
  <p id="abx-status" class="muted"></p>
  <p class="big">Score <span id="abx-score">0 / 0</span>,
     p = <span id="abx-p">1</span></p>
  <p class="hint">p is the exact one-sided binomial probability of scoring at least this well by guessing:
     P(X &ge; k | n, 1/2).</p>
  <ol id="abx-log"></ol>
</section>

<section id="mushra" hidden>
  <h2>MUSHRA (ITU-R BS.1534)</h2>
  <p class="hint">Rate each item against the reference, 0-100 (excellent 80-100, good 60-80,
     fair 40-60, poor 20-40, bad 0-20). One item is the reference itself, hidden: rate it 100.
     One is a low-passed anchor.</p>
  <div class="row"><button id="mushra-ref">Reference</button></div>
  <table id="mushra-items"></table>
  <div class="row"><button id="mushra-submit">Submit ratings</button><span id="mushra-status" class="muted"></span></div>
</section>

<section id="results">
  <h2>Results</h2>
  <div class="row">
    <label>listener <input id="listener" type="text"></label>
    <button id="download-csv">Download CSV</button>
    <button id="download-json">Download JSON</button>
    <span id="server-status" class="muted"></span>
  </div>
  <pre id="results-csv"></pre>
</section>

<section id="reveal-section">
  <h2>Reveal</h2>
  <p id="reveal-hint" class="hint">Which stimulus is which, their loudness, analysis and spectrograms
     appear here when the ABX trials are done@@MUSHRA_TOO@@. Revealing earlier closes the blind tests.
     <button id="reveal-now">Reveal now</button></p>
  <div id="reveal" hidden></div>
</section>

<script type="application/json" id="compare-data">@@DATA@@</script>
@@AUDIO@@
<script>
"use strict";
(function () {
  const DATA = JSON.parse(document.getElementById("compare-data").textContent);
  const $ = (id) => document.getElementById(id);
  const params = new URLSearchParams(location.search);
  const COLUMNS = DATA.columns;
  const STIMULI = DATA.stimuli;
  const BUFFER_IDS = STIMULI.concat(DATA.anchor ? [DATA.anchor] : []);
  const DUR = DATA.duration_s;

  function notice(msg) {
    const n = $("notice");
    n.hidden = false;
    n.textContent += (n.textContent ? " " : "") + msg;
  }

  // ---------------------------------------------------------------- random numbers
  function mulberry32(seed) {
    let a = seed >>> 0;
    return function () {
      a = (a + 0x6D2B79F5) >>> 0;
      let t = a;
      t = Math.imul(t ^ (t >>> 15), t | 1);
      t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
      return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
    };
  }
  function cryptoRandom() {
    const u = new Uint32Array(1);
    crypto.getRandomValues(u);
    return u[0] / 4294967296;
  }
  let seed = null;
  if (params.has("seed")) {
    const s = params.get("seed").trim();
    if (/^[0-9]{1,30}$/.test(s)) seed = Number(BigInt(s) % 4294967296n);
    else notice("?seed=" + s + " is not a whole number: ignored, X is drawn at random.");
  }
  const abxRandom = seed === null ? cryptoRandom : mulberry32(seed);
  const mushraRandom = seed === null ? cryptoRandom : mulberry32((seed ^ 0x9E3779B9) >>> 0);

  // P(X >= k | n, 1/2), exact: integer binomial sums (BigInt), one rounding at the end
  function binomialPValue(k, n) {
    if (k <= 0) return 1;
    if (k > n) return 0;
    let c = 1n, tail = 0n;
    for (let i = 0; i <= n; i++) {
      if (i >= k) tail += c;
      c = c * BigInt(n - i) / BigInt(i + 1);
    }
    return Number(tail) / Number(1n << BigInt(n));
  }

  // ---------------------------------------------------------------- audio
  const buffers = {};
  const decoded = {};
  function base64Bytes(s) {
    const bin = atob(s.replace(/\s+/g, ""));
    const u = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u[i] = bin.charCodeAt(i);
    return u;
  }
  async function decodeAll() {
    const off = new OfflineAudioContext(1, 1, DATA.fs);
    for (const id of BUFFER_IDS) {
      const bytes = base64Bytes($("audio-" + id).textContent);
      const buf = await off.decodeAudioData(bytes.buffer);
      buffers[id] = buf;
      decoded[id] = { length: buf.length, duration: buf.duration, sampleRate: buf.sampleRate,
                      channels: buf.numberOfChannels };
    }
  }

  const player = {
    ctx: null, nodes: null, playing: false, slot: "A", bufferId: STIMULI[0],
    pos0: 0, t0: 0, loop: [0, DUR], starts: 0,
    context() {
      if (!this.ctx) {
        try { this.ctx = new AudioContext({ sampleRate: DATA.fs, latencyHint: "interactive" }); }
        catch (e) { this.ctx = new AudioContext(); }
      }
      if (this.ctx.state !== "running") this.ctx.resume();
      return this.ctx;
    },
    position(now) {
      // now: the context's time to read the playhead at (one read of
      // currentTime for a snapshot; it moves on in steps while a script runs)
      if (!this.playing) return this.pos0;
      const [a, b] = this.loop;
      const t = (now === undefined || now === null) ? this.ctx.currentTime : now;
      let p = this.pos0 + Math.max(0, t - this.t0);
      if (p >= b) p = a + ((p - a) % (b - a));
      return p;
    },
    start() {
      if (!ready) return;
      const ctx = this.context();
      const [a, b] = this.loop;
      let p = this.pos0;
      if (!(p >= a && p < b)) p = a;
      const t0 = ctx.currentTime + 0.03;      // every source starts at this one instant
      this.nodes = {};
      for (const id of BUFFER_IDS) {
        const src = ctx.createBufferSource();
        src.buffer = buffers[id];
        src.loop = true;
        src.loopStart = a;
        src.loopEnd = b;
        const g = ctx.createGain();
        g.gain.value = id === this.bufferId ? 1 : 0;
        src.connect(g).connect(ctx.destination);
        src.start(t0, p);
        this.nodes[id] = { src, gain: g };
      }
      this.starts += 1;
      this.t0 = t0;
      this.pos0 = p;
      this.playing = true;
      requestAnimationFrame(tick);
      updateUI();
    },
    stop() {
      if (!this.playing) return;
      this.pos0 = this.position();
      for (const n of Object.values(this.nodes)) { n.src.stop(); n.src.disconnect(); n.gain.disconnect(); }
      this.nodes = null;
      this.playing = false;
      updateUI();
    },
    // switch to `id` (shown as `slot`) at the same playhead: only the gains move
    select(slot, id) {
      this.slot = slot;
      this.bufferId = id;
      if (this.playing) {
        const now = this.ctx.currentTime;
        for (const [bid, n] of Object.entries(this.nodes)) {
          const g = n.gain.gain;
          if (g.cancelAndHoldAtTime) g.cancelAndHoldAtTime(now); else g.cancelScheduledValues(now);
          g.setTargetAtTime(bid === id ? 1 : 0, now, 0.003);
        }
      }
      updateUI();
    },
    play(slot, id) {
      this.select(slot, id);
      if (!this.playing) this.start();
    },
    seek(t) {
      const was = this.playing;
      if (was) this.stop();
      this.pos0 = Math.min(Math.max(0, t), DUR);
      if (was) this.start(); else updateUI();
    },
    setLoop(a, b) {
      if (!(isFinite(a) && isFinite(b) && a >= 0 && b <= DUR + 1e-9 && b - a >= 0.05)) {
        notice("loop: need 0 <= from < to <= " + DUR.toFixed(2) + " s, at least 0.05 s long.");
        showLoop();
        return false;
      }
      const was = this.playing;
      const p = this.position();
      if (was) this.stop();
      this.loop = [a, Math.min(b, DUR)];
      this.pos0 = p >= a && p < b ? p : a;
      if (was) this.start(); else updateUI();
      showLoop();
      return true;
    },
  };

  // ---------------------------------------------------------------- UI: player
  let ready = false;
  const slotButtons = [];     // [button, slot, id-or-function]
  function slotButton(el, slot, id) {
    slotButtons.push([el, slot, id]);
    el.addEventListener("click", () => {
      const bid = typeof id === "function" ? id() : id;
      if (bid) player.play(slot, bid);
    });
  }
  function fmt(t) { return t.toFixed(2); }
  function showLoop() {
    $("loop-start").value = fmt(player.loop[0]);
    $("loop-end").value = fmt(player.loop[1]);
  }
  function updateUI() {
    $("play").disabled = !ready || player.playing;
    $("stop").disabled = !player.playing;
    $("now-playing").textContent = player.slot + (revealed && labelOf[player.bufferId] && player.slot !== player.bufferId
                                                 ? " (" + player.bufferId + ")" : "");
    for (const [el, slot] of slotButtons) el.classList.toggle("active", slot === player.slot);
    drawTimeline();
  }
  function drawTimeline() {
    const c = $("timeline"), g = c.getContext("2d");
    const w = c.width, h = c.height, [a, b] = player.loop, p = player.position();
    g.clearRect(0, 0, w, h);
    g.fillStyle = "#eef0f5"; g.fillRect(0, 0, w, h);
    g.fillStyle = "#cddcf5"; g.fillRect(a / DUR * w, 0, (b - a) / DUR * w, h);
    g.fillStyle = "#2a5db0"; g.fillRect(Math.round(p / DUR * w) - 1, 0, 2, h);
    $("time").textContent = fmt(p) + " / " + fmt(DUR) + " s";
  }
  function tick() {
    drawTimeline();
    if (player.playing) requestAnimationFrame(tick);
  }
  $("play").addEventListener("click", () => player.start());
  $("stop").addEventListener("click", () => player.stop());
  $("timeline").addEventListener("click", (ev) => {
    const r = ev.target.getBoundingClientRect();
    player.seek((ev.clientX - r.left) / r.width * DUR);
  });
  // an emptied field is being edited: wait for a number (rewriting it now
  // would put the old value back under the listener's typing)
  $("loop-start").addEventListener("change", () => {
    if ($("loop-start").value.trim() !== "") player.setLoop(Number($("loop-start").value), player.loop[1]);
  });
  $("loop-end").addEventListener("change", () => {
    if ($("loop-end").value.trim() !== "") player.setLoop(player.loop[0], Number($("loop-end").value));
  });
  $("loop-set-start").addEventListener("click", () => player.setLoop(player.position(), player.loop[1]));
  $("loop-set-end").addEventListener("click", () => player.setLoop(player.loop[0], player.position()));
  $("loop-all").addEventListener("click", () => player.setLoop(0, DUR));

  for (const id of STIMULI) {
    const b = document.createElement("button");
    b.id = "ab-" + id;
    b.textContent = id;
    $("ab-buttons").appendChild(b);
    slotButton(b, id, id);
  }

  // ---------------------------------------------------------------- results
  const results = [];
  let postChain = Promise.resolve(), saved = 0;
  const served = location.protocol === "http:" || location.protocol === "https:";
  function listener() { return $("listener").value.trim() || "anonymous"; }
  function csvCell(v) {
    if (v === null || v === undefined) return "";
    if (typeof v === "boolean") return v ? "1" : "0";
    let s = String(v);
    // a text cell a spreadsheet would read as a formula gets a leading quote (CSV injection)
    if (typeof v === "string" && /^[=+\-@\t\r]/.test(s)) s = "'" + s;
    return /[",\r\n]/.test(s) ? '"' + s.replace(/"/g, '""') + '"' : s;
  }
  function csvText() {
    const lines = [COLUMNS.join(",")];
    for (const r of results) lines.push(COLUMNS.map((c) => csvCell(r[c])).join(","));
    return lines.join("\n") + "\n";
  }
  function resultsObject() {
    return { format: "synth-compare-results/1", command: DATA.command, page_created: DATA.created,
             listener: listener(), seed: seed, revealed_early: revealedEarly,
             columns: COLUMNS, answers: results,
             abx: abxSummary(), mushra: mushraDone ? mushraSummary() : null };
  }
  function jsonText() { return JSON.stringify(resultsObject(), null, 1) + "\n"; }
  function record(row) {
    const full = { listener: listener(), time: new Date().toISOString() };
    for (const c of COLUMNS) if (row[c] !== undefined) full[c] = row[c];
    results.push(full);
    $("results-csv").textContent = csvText();
    if (served) {
      postChain = postChain.then(async () => {
        try {
          const r = await fetch("answers", { method: "POST", headers: { "Content-Type": "application/json" },
                                             body: JSON.stringify(full) });
          if (!r.ok) throw new Error("HTTP " + r.status);
          saved += 1;
          $("server-status").textContent = saved + " answer(s) saved to answers.csv on the server";
        } catch (e) {
          $("server-status").textContent = "could not save to the server (" + e.message + "): download the CSV";
          console.warn("synth compare: POST answers failed:", e.message);
        }
      });
    }
  }
  function download(name, type, text) {
    const url = URL.createObjectURL(new Blob([text], { type: type }));
    const a = document.createElement("a");
    a.href = url;
    a.download = name;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 5000);
  }
  function stamp() { return new Date().toISOString().replace(/[:.]/g, "-").slice(0, 19); }
  $("download-csv").addEventListener("click", () => download("synth-compare-" + stamp() + ".csv", "text/csv", csvText()));
  $("download-json").addEventListener("click", () => download("synth-compare-" + stamp() + ".json", "application/json", jsonText()));
  {
    let id = params.get("listener");
    try { id = id || localStorage.getItem("synth-compare-listener"); } catch (e) { /* storage off */ }
    if (!id) {
      const u = new Uint32Array(1);
      crypto.getRandomValues(u);
      id = "listener-" + u[0].toString(16).padStart(8, "0");
    }
    $("listener").value = id;
    $("listener").addEventListener("change", () => {
      try { localStorage.setItem("synth-compare-listener", listener()); } catch (e) { /* storage off */ }
    });
  }
  $("results-csv").textContent = csvText();

  // ---------------------------------------------------------------- ABX
  const abx = { a: null, b: null, xs: [], answers: [], k: 0, running: false, done: false };
  for (const sel of ["abx-a", "abx-b"]) {
    for (const id of STIMULI) {
      const o = document.createElement("option");
      o.value = id;
      o.textContent = id;
      $(sel).appendChild(o);
    }
  }
  $("abx-a").value = STIMULI[0];
  $("abx-b").value = STIMULI[1];
  $("abx-start").textContent = "Start " + DATA.trials + " trials";
  if (STIMULI.length === 2) $("abx-pair").querySelectorAll("select").forEach((s) => { s.disabled = true; });
  function abxSummary() {
    const n = abx.answers.length;
    return { a: abx.a, b: abx.b, trials: DATA.trials, answered: n, correct: abx.k,
             p_value: binomialPValue(abx.k, n), done: abx.done };
  }
  function abxButtons() {
    for (const id of ["abx-play-a", "abx-play-b", "abx-play-x", "abx-answer-a", "abx-answer-b"]) {
      $(id).disabled = !abx.running || !ready;
    }
    $("abx-start").disabled = abx.running || abx.done || !ready || revealed;
    $("abx-a").disabled = $("abx-b").disabled = abx.running || abx.done || revealed || STIMULI.length === 2;
  }
  function abxStatus() {
    const n = abx.answers.length;
    $("abx-score").textContent = abx.k + " / " + n;
    $("abx-p").textContent = n ? binomialPValue(abx.k, n).toPrecision(4) : "1";
    if (abx.done) {
      $("abx-status").textContent = "Done: " + abx.k + " of " + n + " correct, p = "
        + binomialPValue(abx.k, n).toPrecision(4) + ".";
    } else if (abx.running) {
      $("abx-status").textContent = "Trial " + (n + 1) + " of " + DATA.trials + ": A = " + abx.a
        + ", B = " + abx.b + ". Which is X?";
    }
  }
  function abxStart() {
    const a = $("abx-a").value, b = $("abx-b").value;
    if (a === b) { $("abx-status").textContent = "Choose two different stimuli for A and B."; return; }
    abx.a = a; abx.b = b; abx.xs = []; abx.answers = []; abx.k = 0;
    for (let i = 0; i < DATA.trials; i++) abx.xs.push(abxRandom() < 0.5 ? a : b);
    abx.running = true;
    $("abx-play-a").textContent = "A (" + a + ")";
    $("abx-play-b").textContent = "B (" + b + ")";
    abxButtons();
    abxStatus();
  }
  function abxX() { return abx.running ? abx.xs[abx.answers.length] : null; }
  function abxAnswer(which) {
    if (!abx.running) return;
    const i = abx.answers.length, x = abx.xs[i];
    const choice = which === "a" ? abx.a : abx.b;
    const correct = choice === x;
    if (correct) abx.k += 1;
    const n = i + 1, p = binomialPValue(abx.k, n);
    abx.answers.push({ choice, correct });
    record({ test: "abx", trial: n, a: abx.a, b: abx.b, x: x, choice: choice, correct: correct,
             score: abx.k, n: n, p_value: p });
    const li = document.createElement("li");
    li.append("X was " + x + ", you said " + choice + ": ");
    const s = document.createElement("span");
    s.className = correct ? "good" : "bad";
    s.textContent = correct ? "right" : "wrong";
    li.append(s);
    $("abx-log").appendChild(li);
    if (n >= DATA.trials) {
      abx.running = false;
      abx.done = true;
    }
    if (player.slot === "X") {
      if (abx.running) player.select("X", abxX()); else player.stop();
    }
    abxButtons();
    abxStatus();
    if (abx.done) maybeReveal();
  }
  $("abx-start").addEventListener("click", abxStart);
  slotButton($("abx-play-a"), "A", () => abx.a);
  slotButton($("abx-play-b"), "B", () => abx.b);
  slotButton($("abx-play-x"), "X", abxX);
  $("abx-answer-a").addEventListener("click", () => abxAnswer("a"));
  $("abx-answer-b").addEventListener("click", () => abxAnswer("b"));

  // ---------------------------------------------------------------- MUSHRA
  const mushraItems = [];
  let mushraDone = false;
  if (DATA.mushra) {
    $("mushra").hidden = false;
    const items = STIMULI.map((id) => ({ stimulus: id, buffer: id }));
    items.push({ stimulus: "hidden-reference", buffer: STIMULI[0] });
    items.push({ stimulus: "anchor", buffer: DATA.anchor });
    for (let i = items.length - 1; i > 0; i--) {          // Fisher-Yates
      const j = Math.floor(mushraRandom() * (i + 1));
      [items[i], items[j]] = [items[j], items[i]];
    }
    slotButton($("mushra-ref"), "reference", STIMULI[0]);
    items.forEach((it, i) => {
      const k = i + 1;
      it.item = k;
      const tr = document.createElement("tr");
      const b = document.createElement("button");
      b.id = "mushra-play-" + k;
      b.textContent = String(k);
      slotButton(b, "item " + k, it.buffer);
      const r = document.createElement("input");
      r.type = "range"; r.min = "0"; r.max = "100"; r.step = "1"; r.value = "0";
      r.id = "mushra-slider-" + k;
      const v = document.createElement("span");
      v.id = "mushra-value-" + k;
      v.textContent = "0";
      r.addEventListener("input", () => { v.textContent = r.value; });
      const who = document.createElement("span");
      who.id = "mushra-who-" + k;
      who.className = "muted";
      const cells = [b, r, v, who];
      for (const c of cells) { const td = document.createElement("td"); td.appendChild(c); tr.appendChild(td); }
      $("mushra-items").appendChild(tr);
      it.slider = r;
      mushraItems.push(it);
    });
  }
  function mushraSummary() {
    return mushraItems.map((it) => ({ item: it.item, stimulus: it.stimulus, rating: Number(it.slider.value) }));
  }
  $("mushra-submit").addEventListener("click", () => {
    if (mushraDone) return;
    mushraDone = true;
    for (const it of mushraItems) {
      record({ test: "mushra", trial: it.item, stimulus: it.stimulus, rating: Number(it.slider.value) });
      it.slider.disabled = true;
    }
    $("mushra-submit").disabled = true;
    $("mushra-status").textContent = "Ratings recorded.";
    maybeReveal();
  });

  // ---------------------------------------------------------------- reveal
  let revealed = false, revealedEarly = false;
  const labelOf = {};
  for (const r of DATA.reveal) labelOf[r.id] = r.label;
  function flatten(obj, prefix, out) {
    for (const [k, v] of Object.entries(obj)) {
      if (v && typeof v === "object" && !Array.isArray(v)) flatten(v, prefix + k + ".", out);
      else out[prefix + k] = v;
    }
    return out;
  }
  function num(v) {
    if (v === null || v === undefined) return "\u2014";
    if (typeof v !== "number") return String(v);
    return Math.abs(v) >= 1000 ? v.toFixed(0) : v.toFixed(2);
  }
  function cell(tr, text, cls, tag) {
    const td = document.createElement(tag || "td");
    td.textContent = text;
    if (cls) td.className = cls;
    tr.appendChild(td);
    return td;
  }
  // the reveal comes when every test of the page is answered (ABX, and MUSHRA if there is one);
  // revealing earlier ends the blind tests
  function maybeReveal() {
    if (abx.done && (!DATA.mushra || mushraDone)) reveal("answered");
  }
  function reveal(reason) {
    if (revealed) return;
    revealed = true;
    revealedEarly = reason === "early";
    abx.running = false;
    abxButtons();
    for (const it of mushraItems) it.slider.disabled = true;
    $("mushra-submit").disabled = true;
    const box = $("reveal");
    box.hidden = false;
    $("reveal-now").disabled = true;
    $("reveal-hint").textContent = reason === "early"
      ? "Revealed before the tests were finished: the blind tests are closed."
      : "The tests are answered: here is what was what.";
    const p = document.createElement("p");
    p.textContent = "Matched to " + num(DATA.level_lufs) + " LUFS (BS.1770 integrated), sample peaks at most "
      + DATA.ceiling_dbfs + " dBFS" + (DATA.limited_db > 0 ? " (lowered " + num(DATA.limited_db) + " dB for that)" : "")
      + ". Command: " + DATA.command;
    box.appendChild(p);
    const t1 = document.createElement("table");
    t1.id = "reveal-stimuli";
    let tr = document.createElement("tr");
    for (const h of ["", "stimulus", "file", "gain dB", "LUFS before", "peak dBFS before"]) cell(tr, h, "", "th");
    t1.appendChild(tr);
    for (const r of DATA.reveal) {
      tr = document.createElement("tr");
      cell(tr, r.id);
      cell(tr, r.label);
      const td = cell(tr, "");
      const a = document.createElement("a");
      a.href = r.file;
      a.textContent = r.file;
      td.appendChild(a);
      cell(tr, num(r.gain_db), "num");
      cell(tr, num(r.original_lufs), "num");
      cell(tr, num(r.original_peak_dbfs), "num");
      t1.appendChild(tr);
    }
    box.appendChild(t1);
    const h = document.createElement("h3");
    h.textContent = "Analysis (as heard, after matching)";
    box.appendChild(h);
    const flat = DATA.reveal.map((r) => flatten(r.analysis || {}, "", {}));
    const keys = [];
    for (const f of flat) for (const k of Object.keys(f)) if (!keys.includes(k)) keys.push(k);
    const t2 = document.createElement("table");
    t2.id = "reveal-analysis";
    tr = document.createElement("tr");
    cell(tr, "", "", "th");
    for (const r of DATA.reveal) cell(tr, r.id, "", "th");
    t2.appendChild(tr);
    for (const k of keys) {
      tr = document.createElement("tr");
      cell(tr, k, "", "th");
      for (const f of flat) cell(tr, num(f[k]), "num");
      t2.appendChild(tr);
    }
    box.appendChild(t2);
    const sp = document.createElement("div");
    sp.className = "spectro";
    if (DATA.spectrograms_note) {
      const n = document.createElement("p");
      n.className = "notice";
      n.textContent = DATA.spectrograms_note;
      sp.appendChild(n);
    }
    for (const r of DATA.reveal) {
      if (!r.spectrogram) continue;
      const fig = document.createElement("figure");
      const img = document.createElement("img");
      img.src = r.spectrogram;
      img.alt = "spectrogram of " + r.id;
      const cap = document.createElement("figcaption");
      cap.textContent = r.id + ": " + r.label;
      fig.append(cap, img);
      sp.appendChild(fig);
    }
    box.appendChild(sp);
    for (const id of STIMULI) $("ab-" + id).title = labelOf[id];
    for (const it of mushraItems) {
      $("mushra-who-" + it.item).textContent = it.stimulus === "hidden-reference"
        ? "hidden reference (" + labelOf[STIMULI[0]] + ")"
        : it.stimulus === "anchor" ? "anchor" : it.stimulus + ": " + labelOf[it.stimulus];
    }
    updateUI();
  }
  $("reveal-now").addEventListener("click", () => reveal("early"));

  // ---------------------------------------------------------------- keys
  document.addEventListener("keydown", (ev) => {
    if (ev.target instanceof HTMLInputElement || ev.target instanceof HTMLSelectElement) return;
    if (ev.ctrlKey || ev.metaKey || ev.altKey) return;
    if (ev.key === " ") {
      ev.preventDefault();
      if (player.playing) player.stop(); else player.start();
    } else if (/^[1-9]$/.test(ev.key) && Number(ev.key) <= STIMULI.length) {
      const id = STIMULI[Number(ev.key) - 1];
      player.play(id, id);
    } else if (abx.running && (ev.key === "a" || ev.key === "b" || ev.key === "x")) {
      $("abx-play-" + ev.key).click();
    }
  });

  // ---------------------------------------------------------------- start
  $("summary").textContent = STIMULI.length + " stimuli (" + STIMULI.join(", ") + "), "
    + DUR.toFixed(2) + " s each, matched to " + DATA.level_lufs.toFixed(1)
    + " LUFS (ITU-R BS.1770), sample peaks at most " + DATA.ceiling_dbfs + " dBFS. "
    + DATA.trials + " ABX trials" + (DATA.mushra ? "; MUSHRA with a hidden reference and a 3.5 kHz anchor." : ".");
  showLoop();
  updateUI();
  abxButtons();
  const readyPromise = decodeAll().then(() => {
    ready = true;
    $("load-status").textContent = "";
    document.documentElement.dataset.ready = "1";
    updateUI();
    abxButtons();
  }, (e) => {
    document.documentElement.dataset.ready = "error";
    $("load-status").textContent = "";
    notice("Decoding the audio failed: " + e);
    console.error("synth compare: decoding the audio failed:", e);
  });

  window.synthCompare = {
    data: DATA, ready: readyPromise, decoded: decoded, seed: seed,
    csv: csvText, json: jsonText, results: () => JSON.parse(JSON.stringify(results)),
    binomialPValue: binomialPValue,
    samples: (id, start, n) => Array.from(buffers[id].getChannelData(0).subarray(start, start + n)),
    prng: (s, n) => { const r = mulberry32(s); return Array.from({ length: n }, r); },
    state: () => {
      // one read of the context's clock: the playhead and the time it is read at agree
      const now = player.ctx ? player.ctx.currentTime : null;
      return { playing: player.playing, slot: player.slot, position: player.position(now),
               starts: player.starts, loop: player.loop.slice(),
               contextState: player.ctx ? player.ctx.state : null, contextTime: now };
    },
    abx: abxSummary,
    mushraItems: () => mushraItems.map((it) => ({ item: it.item })),
    revealed: () => revealed,
  };
})();
</script>
</body>
</html>
"""
