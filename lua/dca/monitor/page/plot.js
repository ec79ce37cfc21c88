// The monitor's plot panel (docs/monitor.md, "The plot"): no dependencies, one canvas. monitor.js makes it with
// window.dcaPlot(api) and hands it the topics, samples, history and series it gets; it draws when told to.
//   api = { send(msg), mode() ('live' | 'replay'), viewTime(), endTime(), ended() (the server is gone), cursor(t),
//           dirty() (draw again at the next frame), seek(t) (replay: the slider to t) }
// Several series from several topics (a topic tree with a filter: a click adds a topic, another removes it), each
// field named from its port (BaseVel[0]) with its unit from the manifest, hidden or shown by a click on the legend; grid, zoom (wheel), pan (drag), hover
// readout, a cursor shared with the timeline (api.cursor, plot.cursorAt); every topic's rows from the first sample
// it got (the server's history of it from the run's start, sent first), bounded by even decimation; a reason in place of an empty
// plot. Replay: the whole run, the slider's time a playhead.
'use strict';
window.dcaPlot = (api) => {
  const $ = (id) => document.getElementById(id);
  const arr = (x) => (Array.isArray(x) ? x : []);
  const KEEP = 4000;  // rows kept per topic: past it every other row goes and the stride doubles
  const COLORS = ['#1565c0', '#c62828', '#2e7d32', '#ef6c00', '#6a1b9a', '#00838f', '#5d4037', '#ad1457', '#9e9d24'];
  const P = {
    topics: new Map(),  // id (text) -> { id, name, fields, units, rows, stride, seen, received, subscribed, asked }
    chosen: [],         // ids in the order chosen
    x: null,            // [t0, t1] once zoomed or panned; null: the whole history (live: following)
    cursor: null,       // the shared cursor's time (this plot's hover, or the timeline's)
    filter: '', collapsed: new Set(), dirtyTree: true,
    hidden: new Set(),  // series hidden by a click on the legend: "topic id:value index"
  };

  const esc = (s) => String(s === undefined || s === null ? '' : s).replace(/[&<>"']/g,
    (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' }[c]));

  // A field's name from its port: "value" is the leaf's port (scale.Out), "value[2]" its element (hit.Force[2]); a
  // world's named field (door_angle) stays.
  function label(t, f) {
    const port = t.name.split('/').filter(Boolean).slice(-2).join('.');  // leaf.Port
    if (f === 'value') return port;
    const m = /^value(\[\d+\])$/.exec(f);
    return m ? port + m[1] : f;
  }

  function topic(id) { return P.topics.get(String(id)); }

  // ------------------------------------------------------------------------------------------ topics and rows

  function setTopics(list) {
    for (const t of list) {
      const id = String(t.id);
      const old = P.topics.get(id);
      if (old) { old.units = arr(t.units); old.history = !!t.history; continue; }
      P.topics.set(id, { id, name: String(t.name), fields: arr(t.fields), units: arr(t.units), history: !!t.history,
        rows: [], stride: 1, seen: 0, received: 0, asked: false });
      P.dirtyTree = true;
    }
    // the topics the server keeps (the world's status: a few, polled anyway, no tap) are followed from the start,
    // chosen or not: after the run's end every one of them is there from its first row
    for (const t of P.topics.values()) if (t.history) ask(t);
  }

  function ask(t) {
    if (t.asked || api.ended()) return;
    t.asked = true;
    api.send(api.mode() === 'live' ? { type: 'subscribe', topic: Number(t.id), rate: 60 } : { type: 'subscribe', topic: t.id });
  }

  // One row, kept when it falls on the topic's stride; past KEEP rows, every other row goes (the first stays).
  function keep(t, r) {
    const n = t.seen++;
    if (n % t.stride !== 0) return;
    t.rows.push(r);
    if (t.rows.length >= KEEP) { t.rows = t.rows.filter((_, i) => i % 2 === 0); t.stride *= 2; }
  }

  function samples(m) {
    const t = topic(m.topic);
    if (!t) return false;
    const rows = arr(m.rows);
    for (const r of rows) if (!t.rows.length || r[0] >= t.rows[t.rows.length - 1][0]) keep(t, r);
    t.received += rows.length;
    return P.chosen.includes(t.id);
  }

  // The server's history of a topic (from the run's start): it goes before what came since.
  function history(m) {
    const t = topic(m.topic);
    if (!t) return false;
    const rows = arr(m.rows);
    const last = rows.length ? rows[rows.length - 1][0] : -Infinity;
    const after = t.rows.filter((r) => r[0] > last);
    t.rows = []; t.seen = 0; t.stride = 1;
    for (const r of rows) keep(t, r);
    for (const r of after) keep(t, r);
    t.received += rows.length;
    return P.chosen.includes(t.id);
  }

  // A recorded signal (replay): its rows whole.
  function series(m) {
    const t = topic(m.topic);
    if (!t) return false;
    t.rows = arr(m.rows);
    t.received = t.rows.length;
    return P.chosen.includes(t.id);
  }

  // A topic chosen, or chosen no more. Live, a topic once chosen stays subscribed (its rows go on growing, so
  // choosing it again shows it from its first sample); a replay's rows come once.
  function toggle(id) {
    const t = topic(id);
    if (!t) return;
    const i = P.chosen.indexOf(t.id);
    if (i >= 0) P.chosen.splice(i, 1);
    else {
      P.chosen.push(t.id);
      ask(t);
    }
    P.dirtyTree = true;
  }

  function clear() { P.chosen = []; P.x = null; P.dirtyTree = true; }

  // ------------------------------------------------------------------------------------------ the topic tree

  // The topics as a tree of their path's parts; with a filter, only the topics whose name has it (any case).
  function renderTree() {
    P.dirtyTree = false;
    const f = P.filter.toLowerCase();
    const root = { kids: new Map(), topics: [] };
    for (const t of P.topics.values()) {
      if (f && !t.name.toLowerCase().includes(f)) continue;
      const parts = t.name.split('/').filter(Boolean);
      let node = root;
      for (const p of parts.slice(0, -1)) {
        if (!node.kids.has(p)) node.kids.set(p, { kids: new Map(), topics: [] });
        node = node.kids.get(p);
      }
      node.topics.push(t);
    }
    let html = '';
    const walk = (node, path, depth) => {
      for (const [name, k] of node.kids) {
        // a group of one group is drawn as one row (main/dooropensyst/motionctrl)
        let p = path + '/' + name, kk = k, shown = name;
        while (kk.kids.size === 1 && !kk.topics.length) {
          const [n2, k2] = [...kk.kids][0];
          p += '/' + n2; shown += '/' + n2; kk = k2;
        }
        const open = f || !P.collapsed.has(p);
        html += `<div class="pgroup" data-group="${esc(p)}" style="padding-left:${depth * 12}px">` +
          `${open ? '▾' : '▸'} ${esc(shown)}</div>`;
        if (open) walk(kk, p, depth + 1);
      }
      for (const t of node.topics) {
        const on = P.chosen.includes(t.id);
        const n = t.rows.length;
        html += `<div class="ptopic${on ? ' chosen' : ''}" data-id="${esc(t.id)}" data-name="${esc(t.name)}"` +
          ` style="padding-left:${depth * 12}px" title="${esc(t.name)}: ${esc(t.fields.join(', '))}">` +
          `<span class="mark">${on ? '☑' : '☐'}</span> ${esc(t.name.slice(t.name.lastIndexOf('/') + 1))}` +
          `<span class="pcount">${n ? n : ''}</span></div>`;
      }
    };
    walk(root, '', 0);
    $('plot-topics').innerHTML = html || '<div class="pnone">no signal matches</div>';
  }

  $('plot-topics').addEventListener('click', (ev) => {
    const g = ev.target.closest('.pgroup');
    if (g) {
      const p = g.dataset.group;
      if (P.collapsed.has(p)) P.collapsed.delete(p); else P.collapsed.add(p);
      P.dirtyTree = true;
      api.dirty();
      return;
    }
    const row = ev.target.closest('.ptopic');
    if (row) toggle(row.dataset.id);
    api.dirty();
  });
  $('plot-filter').addEventListener('input', () => { P.filter = $('plot-filter').value; P.dirtyTree = true; api.dirty(); });
  $('legend').addEventListener('click', (ev) => {
    const k = ev.target.closest('.pseries')?.dataset.key;
    if (!k) return;
    if (P.hidden.has(k)) P.hidden.delete(k); else P.hidden.add(k);
    api.dirty();
  });
  $('plot-reset').addEventListener('click', () => { P.x = null; api.dirty(); });
  $('plot-clear').addEventListener('click', () => { clear(); api.dirty(); });

  // ------------------------------------------------------------------------------------------ drawing

  // The plotted series: { t (topic), k (the value's index in a row), name, unit, color }.
  function seriesList() {
    const out = [];
    for (const id of P.chosen) {
      const t = topic(id);
      if (!t) continue;
      // (a port of varying size has no fields: its rows say how many values it has)
      const fields = t.fields.length ? t.fields
        : Array.from({ length: t.rows.length ? t.rows[0].length - 1 : 0 }, (_, i) => `value[${i}]`);
      fields.forEach((f, i) => out.push({ t, k: i + 1, key: `${t.id}:${i + 1}`, name: label(t, f), field: f,
        unit: (t.units.length === fields.length ? t.units[i] : t.units[0]) || '', color: COLORS[out.length % COLORS.length] }));
    }
    return out;
  }

  // The x range shown: zoomed, or the whole run in replay, or the history so far live.
  function xRange(list) {
    if (P.x) return P.x;
    if (api.mode() === 'replay') return [0, Math.max(api.endTime(), 1e-3)];
    let t0 = Infinity, t1 = -Infinity;
    for (const s of list) {
      const r = s.t.rows;
      if (r.length) { t0 = Math.min(t0, r[0][0]); t1 = Math.max(t1, r[r.length - 1][0]); }
    }
    if (t0 === Infinity) return [0, Math.max(api.viewTime(), 1)];
    return [Math.min(t0, 0), Math.max(t1, t0 + 1e-3)];
  }

  // The index of the first row at or after t (rows in time order).
  function lower(rows, t) {
    let lo = 0, hi = rows.length;
    while (lo < hi) { const m = (lo + hi) >> 1; if (rows[m][0] < t) lo = m + 1; else hi = m; }
    return lo;
  }

  // About n round steps between lo and hi (1, 2 or 5 times a power of ten).
  function ticks(lo, hi, n) {
    const raw = (hi - lo) / n;
    if (!(raw > 0) || !isFinite(raw)) return { list: [], step: 1 };
    const p = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 5, 10].map((m) => m * p).find((s) => s >= raw) || raw;
    const out = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9 && out.length < 100; v += step) {
      out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
    }
    return { list: out, step };
  }
  const fmt = (v, step) => v.toFixed(Math.max(0, Math.min(6, -Math.floor(Math.log10(step)))));

  const L = 56, R = 10, TOP = 8, B = 22;  // the frame's margins (px)
  let frame = null;  // the last drawing's geometry, for the mouse

  // The reason the plot is empty, or '' when it has something to draw.
  function reason(list) {
    if (!P.topics.size) return api.ended() ? 'the run has ended: it offered no signal' : 'no signal yet: the run offers none so far';
    if (!P.chosen.length) return 'choose one or more signals in the list (a click adds one, another removes it)';
    const empty = P.chosen.map(topic).filter((t) => t && !t.rows.length);
    if (empty.length < P.chosen.length) return '';
    const names = empty.map((t) => t.name).join(', ');
    if (api.mode() === 'replay') return `${names}: no rows in the recording`;
    if (api.ended()) return `${names}: no samples, and the run has ended (a port sends only once it is tapped, ` +
      'when first chosen, and while its process runs)';
    return `${names}: no samples yet (a port is tapped when first chosen, and sends while its process runs` +
      `${document.body.dataset.clock === 'paused' ? '; time is paused' : ''})`;
  }

  // One series' line from t0 to t1 (and one row either side). Past two rows a pixel column, each column is drawn
  // as its first value, its lowest, its highest and its last: the same envelope for a fraction of the lines.
  function trace(g, s, t0, t1, X, Y) {
    const r = s.t.rows, from = Math.max(0, lower(r, t0) - 1), to = Math.min(r.length, lower(r, t1) + 1);
    const dense = to - from > 2 * (X(t1) - X(t0));
    let first = true, col = null, lo = 0, hi = 0, last = 0;
    const flush = () => { if (col !== null) { g.lineTo(col, Y(lo)); g.lineTo(col, Y(hi)); g.lineTo(col, Y(last)); } };
    for (let i = from; i < to; i++) {
      const v = r[i][s.k];
      if (typeof v !== 'number') continue;
      const x = X(r[i][0]);
      if (first) { g.moveTo(x, Y(v)); first = false; continue; }
      if (!dense) { g.lineTo(x, Y(v)); continue; }
      const cx = Math.round(x);
      if (cx !== col) { flush(); col = cx; lo = hi = v; g.lineTo(cx, Y(v)); } else { lo = Math.min(lo, v); hi = Math.max(hi, v); }
      last = v;
    }
    flush();
  }

  let lastLegend = null;
  function render() {
    if (P.dirtyTree) renderTree();
    for (const row of $('plot-topics').querySelectorAll('.ptopic')) {  // the rows kept, in place
      const t = topic(row.dataset.id), n = t && t.rows.length ? String(t.rows.length) : '';
      const span = row.querySelector('.pcount');
      if (span.textContent !== n) span.textContent = n;
    }
    const c = $('plot');
    const all = seriesList(), list = all.filter((s) => !P.hidden.has(s.key));
    const w = c.clientWidth || 400, h = c.clientHeight || 220;
    c.width = w; c.height = h;
    const g = c.getContext('2d');
    g.clearRect(0, 0, w, h);
    let n = 0;
    for (const id of P.chosen) { const t = topic(id); if (t) n += api.mode() === 'replay' ? t.rows.length : t.received; }
    c.dataset.samples = String(n);
    c.dataset.series = String(list.length);
    const why = reason(list);
    $('plot-reason').textContent = why;
    $('plot-reason').hidden = !why;
    const legend = all.map((s) => `<span class="pseries${P.hidden.has(s.key) ? ' off' : ''}" ` +
      `data-key="${esc(s.key)}" style="color:${s.color}" title="${esc(s.t.name)} ${esc(s.field)} (a click hides or ` +
      `shows it)">${esc(s.name)}${s.unit ? ` <small>${esc(s.unit)}</small>` : ''}</span>`).join('');
    if (legend !== lastLegend) { $('legend').innerHTML = legend; lastLegend = legend; }  // (only when it changed)
    const [t0, t1] = xRange(list);
    c.dataset.x0 = t0.toFixed(3); c.dataset.x1 = t1.toFixed(3);
    let lo = Infinity, hi = -Infinity;
    for (const s of list) {
      const r = s.t.rows;
      for (let i = Math.max(0, lower(r, t0) - 1); i < r.length && (i === 0 || r[i - 1][0] <= t1); i++) {
        const v = r[i][s.k];
        if (typeof v === 'number' && isFinite(v)) { if (v < lo) lo = v; if (v > hi) hi = v; }
      }
    }
    if (lo === Infinity) { lo = -1; hi = 1; }
    if (hi - lo < 1e-9) { hi += 1; lo -= 1; }
    const pad = (hi - lo) * 0.05; lo -= pad; hi += pad;
    const X = (t) => L + (t - t0) / (t1 - t0) * (w - L - R), Y = (v) => TOP + (hi - v) / (hi - lo) * (h - TOP - B);
    frame = { t0, t1, w, h, X, T: (x) => t0 + (x - L) / (w - L - R) * (t1 - t0) };
    // the grid and its labels
    g.font = '10px sans-serif'; g.lineWidth = 1;
    const xt = ticks(t0, t1, Math.max(2, Math.floor((w - L) / 90))), yt = ticks(lo, hi, Math.max(2, Math.floor(h / 40)));
    g.strokeStyle = '#e6e6e6'; g.fillStyle = '#555';
    for (const v of xt.list) {
      const x = Math.round(X(v)) + 0.5;
      g.beginPath(); g.moveTo(x, TOP); g.lineTo(x, h - B); g.stroke();
      g.fillText(fmt(v, xt.step) + ' s', x - 12, h - 8);
    }
    for (const v of yt.list) {
      const y = Math.round(Y(v)) + 0.5;
      g.beginPath(); g.moveTo(L, y); g.lineTo(w - R, y); g.stroke();
      g.fillText(fmt(v, yt.step), 2, y + 3);
    }
    g.strokeStyle = '#999'; g.strokeRect(L + 0.5, TOP + 0.5, w - L - R, h - TOP - B);
    // the series, clipped to the frame
    g.save(); g.beginPath(); g.rect(L, TOP, w - L - R, h - TOP - B); g.clip();
    for (const s of list) {
      g.strokeStyle = s.color; g.lineWidth = 1.5; g.beginPath();
      trace(g, s, t0, t1, X, Y);
      g.stroke();
    }
    g.restore();
    // replay: the slider's time; both: the shared cursor, and its readout
    if (api.mode() === 'replay') {
      const x = Math.round(X(api.viewTime())) + 0.5;
      g.strokeStyle = '#d32f2f'; g.lineWidth = 2;
      g.beginPath(); g.moveTo(x, TOP); g.lineTo(x, h - B); g.stroke();
      c.dataset.playhead = api.viewTime().toFixed(3);
    }
    readout(list, g);
  }

  // The value of each series at the cursor (the last row at or before it), beside the cursor's line.
  function readout(list, g) {
    const box = $('plot-readout');
    if (P.cursor === null || !frame || !list.length) { box.hidden = true; $('plot').dataset.cursor = ''; return; }
    const t = P.cursor, x = Math.round(frame.X(t)) + 0.5;
    g.strokeStyle = '#444'; g.setLineDash([4, 3]); g.lineWidth = 1;
    g.beginPath(); g.moveTo(x, TOP); g.lineTo(x, frame.h - B); g.stroke(); g.setLineDash([]);
    const lines = [`t = ${t.toFixed(3)} s`];
    for (const s of list) {
      const r = s.t.rows, i = lower(r, t + 1e-12) - 1;
      const v = i >= 0 ? r[i][s.k] : undefined;
      lines.push(`<span style="color:${s.color}">${esc(s.name)}</span> = ` +
        `<b>${typeof v === 'number' ? esc(Number(v.toPrecision(6))) : '–'}</b>${s.unit ? ' ' + esc(s.unit) : ''}`);
    }
    box.innerHTML = lines.join('<br>');
    box.hidden = false;
    box.style.left = Math.min(frame.w - 180, x + 8) + 'px';
    $('plot').dataset.cursor = t.toFixed(3);
  }

  // ------------------------------------------------------------------------------------------ the mouse

  const c = $('plot');
  let drag = null, dragged = false;
  const tAt = (ev) => frame && frame.T(ev.offsetX);
  c.addEventListener('mousemove', (ev) => {
    if (!frame) return;
    if (drag && Math.abs(ev.offsetX - drag.x) > 2) drag.moved = true;
    if (drag && drag.moved) {  // pan: the time under the pointer stays under it
      const dt = (ev.offsetX - drag.x) / (frame.w - L - R) * (drag.range[1] - drag.range[0]);
      P.x = [drag.range[0] - dt, drag.range[1] - dt];
    }
    P.cursor = tAt(ev);
    api.cursor(P.cursor);
    api.dirty();
  });
  c.addEventListener('mouseleave', () => { drag = null; P.cursor = null; api.cursor(null); api.dirty(); });
  c.addEventListener('mousedown', (ev) => { if (frame) drag = { x: ev.offsetX, range: [frame.t0, frame.t1] }; });
  window.addEventListener('mouseup', () => { dragged = !!drag && drag.moved; drag = null; });
  // replay: a click (not the end of a drag) moves the slider to the time clicked
  c.addEventListener('click', (ev) => {
    if (frame && api.mode() === 'replay' && !dragged) api.seek(frame.T(ev.offsetX));
  });
  // zoom: the wheel, around the time under the pointer
  c.addEventListener('wheel', (ev) => {
    if (!frame) return;
    ev.preventDefault();
    const t = frame.T(ev.offsetX), k = ev.deltaY > 0 ? 1.25 : 0.8;
    if (k < 1 && frame.t1 - frame.t0 < 1e-4) return;  // (no closer than 0.1 ms across)
    P.x = [t - (t - frame.t0) * k, t + (frame.t1 - t) * k];
    api.dirty();
  }, { passive: false });
  c.addEventListener('dblclick', () => { P.x = null; api.dirty(); });

  return {
    P, setTopics, samples, history, series, toggle, clear, render,
    // the timeline's hover: the same cursor here
    cursorAt(t) { P.cursor = t; },
    zoom(t0, t1) { P.x = t0 === null ? null : [t0, t1]; },
    label,
  };
};
