// The dca monitor's page: no dependencies. It speaks `dca.monitor.v1` (lua/dca/monitor/server.lua) over one
// WebSocket: a snapshot, then deltas; every view is redrawn at most once per animation frame, and only the parts
// that changed. Live: the view is the run now. Replay: the view is the recording at the slider's time.
'use strict';
(() => {
  const $ = (id) => document.getElementById(id);
  const arr = (x) => (Array.isArray(x) ? x : []);
  const obj = (x) => (x && typeof x === 'object' && !Array.isArray(x) ? x : {});
  const token = new URLSearchParams(location.search).get('token') || '';
  const ROW = 18;            // px per tree row (the tree is virtualised: only rows in view are in the page)
  const BIG_GROUP = 30;      // groups with more children start collapsed
  const PLOT_KEEP = 4000;    // the robot's rows kept

  const S = {
    mode: 'live', nodes: new Map(), order: [], kids: new Map(), exprs: {}, events: [], config: new Map(),
    lines: [], topics: new Map(), series: new Map(), t: 0, viewT: 0, expanded: new Set(), collapsed: new Set(),
    replayStates: null, playing: false, ended: false, cursor: null, ws: null,
    nextId: 1, estop: null, clock: null,
    dirty: { tree: true, states: true, exprs: true, timeline: true, plot: true, config: true, lines: true,
      rt: true, pace: true },
  };

  // ------------------------------------------------------------------------------------------ the model

  function addNode(n) {
    const old = S.nodes.get(n.path);
    if (!old) {
      S.order.push(n.path);
      const list = S.kids.get(n.parent) || [];
      list.push(n.path);
      S.kids.set(n.parent, list);
      S.dirty.tree = true;
    } else if (old.host !== n.host || old.kind !== n.kind || old.type !== n.type) {
      S.dirty.tree = true;
    }
    S.nodes.set(n.path, Object.assign(old || {}, n));
    if (n.rt) S.dirty.rt = true;
  }

  function snapshot(m) {
    S.nodes.clear(); S.order = []; S.kids.clear(); S.events = []; S.config.clear(); S.lines = [];
    S.exprs = obj(m.exprs);
    arr(m.nodes).forEach(addNode);
    S.events = arr(m.events);
    arr(m.config).forEach((c) => S.config.set(c.key, c));
    S.lines = arr(m.lines);
    S.estop = estopOf(S.lines, null);
    setTopics(arr(m.topics));
    S.t = m.t || 0;
    if (m.clock) paceClock(m.clock);
    if (S.mode === 'replay') replayRange();
    markAll();
  }

  function delta(m) {
    arr(m.nodes).forEach(addNode);
    Object.assign(S.exprs, obj(m.exprs));
    if (Object.keys(obj(m.exprs)).length) S.dirty.exprs = true;
    const evs = arr(m.events);
    evs.forEach((e) => S.events.push(e));
    arr(m.config).forEach((c) => { S.config.set(c.key, Object.assign({ changed: Date.now() }, c)); });
    arr(m.lines).forEach((l) => S.lines.push(l));
    S.estop = estopOf(arr(m.lines), S.estop);  // (kept apart: the lines are cut to the last 300)
    if (S.lines.length > 300) S.lines.splice(0, S.lines.length - 300);
    if (m.topics) setTopics(arr(m.topics));
    S.t = Math.max(S.t, m.t || 0);
    if (m.clock) paceClock(m.clock);
    if (evs.length || arr(m.nodes).length) { S.dirty.states = true; S.dirty.timeline = true; }
    if (arr(m.config).length) S.dirty.config = true;
    if (arr(m.lines).length) S.dirty.lines = true;
  }

  function markAll() { for (const k of Object.keys(S.dirty)) S.dirty[k] = true; }

  // The state of process `path` in the view (live: now; replay: at the slider's time).
  function stateOf(path) {
    if (S.mode === 'replay') return (S.replayStates && S.replayStates.get(path)) || { state: 'new' };
    return S.nodes.get(path) || { state: 'new' };
  }

  // ------------------------------------------------------------------------------------------ the tree

  // Expanded unless closed by hand; a group of more than BIG_GROUP children starts closed, the root never.
  function isExpanded(path) {
    if (S.collapsed.has(path)) return false;
    if (S.expanded.has(path)) return true;
    const n = S.nodes.get(path);
    return (n && !S.nodes.has(n.parent)) || (S.kids.get(path) || []).length <= BIG_GROUP;
  }

  // The rows in view order: every process whose ancestors are expanded.
  function visibleRows() {
    const out = [];
    const walk = (path, depth) => {
      out.push({ path, depth });
      if (!isExpanded(path)) return;
      for (const k of S.kids.get(path) || []) walk(k, depth + 1);
    };
    for (const p of S.order) if (!S.nodes.has(S.nodes.get(p).parent)) walk(p, 0);
    return out;
  }

  function rowHtml(r) {
    const n = S.nodes.get(r.path);
    const st = stateOf(r.path);
    const kids = (S.kids.get(r.path) || []).length;
    const name = r.path.slice(r.path.lastIndexOf('.') + 1);
    const toggle = kids ? (isExpanded(r.path) ? '▾' : '▸') : '';
    const live = S.mode === 'live';
    return `<div class="row" data-path="${esc(r.path)}" data-host="${esc(n.host)}" data-kind="${esc(n.kind)}"` +
      ` data-state="${esc(st.state)}" style="padding-left:${r.depth * 14}px">` +
      `<span class="toggle">${toggle}</span><span class="name">${esc(name)}</span>` +
      `<span class="state state-${esc(st.state)}">${esc(st.state)}</span>` +
      `<span class="type">${esc(n.type)}${kids ? ` (${kids})` : ''}</span><span class="host">@${esc(n.host)}</span>` +
      `<span class="restarts">${n.restarts ? '↻' + n.restarts : ''}</span>` +
      `<span class="fault" title="${esc(st.fault || '')}">${esc(st.fault || '')}</span>` +
      (live ? '<button data-cmd="restart">restart</button><button data-cmd="abort">abort</button>' : '') +
      (live ? fleetButtons(r.path, n) : '') + '</div>';
  }

  // A fleet (docs/supervision.md, "A fleet"): a group's templates each get an add button (the host asked for), an
  // instance of one a remove button.
  function fleetButtons(path, n) {
    const parent = S.nodes.get(n.parent);
    const tpl = parent && arr(parent.fleet).find((t) => path.startsWith(t.path + '_'));
    let html = tpl ? '<button data-cmd="remove_child">remove</button>' : '';
    for (const t of arr(n.fleet)) {
      html += `<button data-cmd="add_child" data-tpl="${esc(t.path)}" data-hosts="${esc(arr(t.hosts).join(' '))}">` +
        `+${esc(t.path.slice(t.path.lastIndexOf('.') + 1))}</button>`;
    }
    return html;
  }

  let treeRows = [], treeWindow = [];
  function renderTree() {
    const box = $('tree');
    treeRows = visibleRows();
    $('tree-count').textContent = `(${S.nodes.size} processes)`;
    const pane = $('tree-pane');
    const first = Math.max(0, Math.floor((pane.scrollTop - 30) / ROW) - 20);
    const last = Math.min(treeRows.length, first + Math.ceil(pane.clientHeight / ROW) + 60);
    let html = `<div style="height:${first * ROW}px"></div>`;
    for (let i = first; i < last; i++) html += rowHtml(treeRows[i]);
    treeWindow = treeRows.slice(first, last);
    html += `<div style="height:${(treeRows.length - last) * ROW}px"></div>`;
    box.innerHTML = html;
  }

  $('tree').addEventListener('click', (ev) => {
    const row = ev.target.closest('.row');
    if (!row) return;
    const path = row.dataset.path;
    if (ev.target.dataset.cmd === 'add_child') {
      const hosts = ev.target.dataset.hosts.split(' ');
      const host = window.prompt(`Host of the new instance of ${ev.target.dataset.tpl} (${hosts.join(', ')})`, hosts[0]);
      if (host) command({ cmd: 'add_child', path: ev.target.dataset.tpl, host });
      return;
    }
    if (ev.target.dataset.cmd) { command({ cmd: ev.target.dataset.cmd, path }); return; }
    if (ev.target.classList.contains('toggle')) {
      if (isExpanded(path)) { S.collapsed.add(path); S.expanded.delete(path); }
      else { S.expanded.add(path); S.collapsed.delete(path); }
      S.dirty.tree = true; S.dirty.exprs = true;
    }
  });
  $('tree-pane').addEventListener('scroll', () => { S.dirty.tree = true; });
  $('timeline-box').addEventListener('scroll', () => { S.dirty.timeline = true; });

  // ------------------------------------------------------------------------------------------ expressions

  const OPS = { ',': 'par', ';': 'seq', '#': 'dis', ':': 'cond', ':;': 'rec' };
  function exprHtml(group, e) {
    if (!e) return '';
    if (e.op === 'leaf') {
      const path = group + '.' + e.name;
      const label = e.label ? `[${esc(e.label)}]` : '';
      return `<span class="leaf" data-path="${esc(path)}">${esc(e.name)}${label}</span>`;
    }
    const kids = arr(e.kids).map((k) => exprHtml(group, k));
    return `<span class="op op-${OPS[e.op] || 'x'}" title="${esc(e.op)}">` +
      kids.join(`<span class="sym">${esc(e.op)}</span>`) + '</span>';
  }

  // The expressions of the expanded groups in the tree's window (what the tree shows, so a big tree costs what a
  // screenful costs).
  function renderExprs() {
    let html = '';
    for (const r of treeWindow) {
      const e = S.exprs[r.path];
      if (e && isExpanded(r.path)) html += `<div class="expr" data-group="${esc(r.path)}"><h3>${esc(r.path)}</h3>${exprHtml(r.path, e)}</div>`;
    }
    $('exprs').innerHTML = html;
    S.dirty.states = true;
  }

  // States changed: the tree's badges and the expressions' highlights, in place.
  function renderStates() {
    for (const row of $('tree').querySelectorAll('.row')) {
      const st = stateOf(row.dataset.path);
      const restarts = (S.nodes.get(row.dataset.path) || {}).restarts;
      const key = `${st.state}|${st.fault || ''}|${restarts || 0}`;
      if (row.dataset.shown === key) continue;
      row.dataset.shown = key;
      row.dataset.state = st.state;
      const badge = row.querySelector('.state');
      badge.className = `state state-${st.state}`;
      badge.textContent = st.state;
      const fault = row.querySelector('.fault');
      fault.textContent = st.fault || '';
      fault.title = st.fault || '';
      row.querySelector('.restarts').textContent = restarts ? '↻' + restarts : '';
    }
    for (const leaf of $('exprs').querySelectorAll('.leaf')) {
      const st = stateOf(leaf.dataset.path).state;
      leaf.classList.toggle('running', st === 'running');
      leaf.classList.toggle('done', st === 'done');
      leaf.classList.toggle('aborted', st === 'aborted' || st === 'exited' || st === 'lost');
    }
  }

  // ------------------------------------------------------------------------------------------ timeline

  // Each process that ran: its periods [start, end) up to time T.
  function periods(T) {
    const rows = new Map();
    for (const e of S.events) {
      if (e.t > T) break;
      let r = rows.get(e.path);
      if (e.state === 'running') {
        if (!r) { r = []; rows.set(e.path, r); }
        if (!r.length || r[r.length - 1].end !== undefined) r.push({ start: e.t });
      } else if (r && r.length && r[r.length - 1].end === undefined) {
        r[r.length - 1].end = e.t; r[r.length - 1].how = e.state === 'aborting' ? 'stopped' : e.state;
      }
    }
    return rows;
  }

  // The timeline is one canvas the size of its box, drawing the rows scrolled into view; a spacer gives the box
  // the whole height.
  // Replay: the whole run, the slider's time a playhead. Both: the cursor shared with the plot (S.cursor).
  function renderTimeline() {
    const T = S.mode === 'replay' ? S.t : viewTime();
    const rows = periods(T);
    const c = $('timeline'), box = $('timeline-box');
    const w = box.clientWidth || 600;
    const total = 20 + rows.size * 14;
    const h = Math.min(total, 320);
    $('timeline-spacer').style.height = Math.max(0, total - h) + 'px';
    c.width = w; c.height = h; c.style.height = h + 'px';
    const skip = Math.max(0, Math.min(rows.size, Math.floor(box.scrollTop / 14)));
    const g = c.getContext('2d');
    const label = 220, span = Math.max(T, 1e-3);
    const x = (t) => label + (t / span) * (w - label - 10);
    g.font = '10px sans-serif'; g.fillStyle = '#555';
    for (let k = 0; k <= 5; k++) g.fillText((span * k / 5).toFixed(2), x(span * k / 5) - 8, 10);
    let y = 16, i = 0;
    for (const [path, list] of rows) {
      if (i++ < skip) continue;
      if (y > h) break;
      g.fillStyle = '#333';
      g.fillText(path.length > 38 ? '…' + path.slice(-37) : path, 2, y + 9);
      for (const p of list) {
        const end = p.end === undefined ? T : p.end;
        g.fillStyle = p.end === undefined ? '#43a047' : (p.how === 'done' ? '#1e88e5' : (p.how === 'stopped' ? '#90a4ae' : '#e53935'));
        g.fillRect(x(p.start), y + 1, Math.max(1, x(end) - x(p.start)), 10);
      }
      y += 14;
    }
    c.dataset.rows = String(rows.size);
    timelineX = { x0: label, span, w: w - label - 10 };
    const mark = (t, color, dash) => {
      const px = Math.round(x(t)) + 0.5;
      g.strokeStyle = color; g.setLineDash(dash); g.lineWidth = dash.length ? 1 : 2;
      g.beginPath(); g.moveTo(px, 12); g.lineTo(px, h); g.stroke(); g.setLineDash([]);
    };
    if (S.mode === 'replay') mark(S.viewT, '#d32f2f', []);
    if (S.cursor !== null && S.cursor >= 0 && S.cursor <= span) mark(S.cursor, '#444', [4, 3]);
    c.dataset.cursor = S.cursor === null ? '' : S.cursor.toFixed(3);
  }

  // The timeline's hover moves the cursor the plot shares.
  let timelineX = null;
  $('timeline').addEventListener('mousemove', (ev) => {
    if (!timelineX || ev.offsetX < timelineX.x0) return;
    S.cursor = (ev.offsetX - timelineX.x0) / timelineX.w * timelineX.span;
    plot.cursorAt(S.cursor);
    S.dirty.timeline = true; S.dirty.plot = true;
  });
  $('timeline').addEventListener('mouseleave', () => {
    S.cursor = null; plot.cursorAt(null); S.dirty.timeline = true; S.dirty.plot = true;
  });

  // ------------------------------------------------------------------------------------------ plot

  // The plot panel is plot.js (window.dcaPlot): the topics, samples, history and series go to it; it draws when
  // the plot is dirty. Its cursor and the timeline's are one (S.cursor).
  const plot = window.dcaPlot({
    send: (m) => send(m), mode: () => S.mode, viewTime: () => viewTime(), endTime: () => S.t,
    ended: () => S.ended, cursor: (t) => { S.cursor = t; S.dirty.timeline = true; }, dirty: () => { S.dirty.plot = true; },
    seek: (t) => { S.playing = false; $('play').textContent = 'play'; seek(t); },
  });
  window.dcaPlotPanel = plot;  // for tests and the curious
  function setTopics(list) { plot.setTopics(list); S.dirty.plot = true; }
  function samples(m) {
    if (S.robot && String(m.topic) === String(S.robot.topic)) robotRows(arr(m.rows));
    if (plot.samples(m)) S.dirty.plot = true;
  }
  function renderPlot() { plot.render(); }

  // ------------------------------------------------------------------------------------------ config, lines

  function renderConfig() {
    const body = $('config').tBodies[0];
    const keys = [...S.config.keys()].sort();
    body.innerHTML = keys.map((k) => {
      const c = S.config.get(k);
      const changed = c.changed && Date.now() - c.changed < 3000 ? ' class="changed"' : '';
      return `<tr data-key="${esc(k)}"${changed}><td>${esc(k)}</td><td>${esc(c.value)}</td><td>${esc(c.origin || '')}</td></tr>`;
    }).join('');
  }

  // The leaves on a real-time thread (docs/time.md, "Real time"): their figures as the server last asked them.
  function us(v) {
    const x = Number(v) || 0;
    return x >= 1000 ? `${(x / 1000).toFixed(3)} ms` : `${x.toFixed(0)} us`;
  }
  function renderRt() {
    const rows = S.order.map((p) => S.nodes.get(p)).filter((n) => n && n.rt);
    $('rt-pane').hidden = rows.length === 0;
    $('rt').tBodies[0].innerHTML = rows.map((n) => {
      const r = obj(n.rt);
      return `<tr data-path="${esc(n.path)}"${r.overruns ? ' class="overrun"' : ''}><td>${esc(n.path)}</td>` +
        `<td class="runs">${esc(r.runs)}</td><td>${r.period_s ? us(r.period_s * 1e6) : '-'}</td>` +
        `<td class="wake">${us(r.wake_p50_us)} / ${us(r.wake_p99_us)} / ${us(r.wake_max_us)}</td>` +
        `<td class="exec">${us(r.exec_p50_us)} / ${us(r.exec_p99_us)} / ${us(r.exec_max_us)}</td>` +
        `<td class="overruns">${esc(r.overruns)} (${esc(r.missed)})</td></tr>`;
    }).join('');
  }

  // The robot's emergency stop as the root said it last (docs/safety.md): `main: emergency stop pressed by SOURCE
  // at T s` (or released), among `lines`; the last state before them when none is there.
  function estopOf(lines, before) {
    let e = before;
    for (const l of lines) {
      const m = /^([^ .:]+): emergency stop (pressed|released) by (.*) at ([0-9.]+) s$/.exec(String(l.line));
      if (m) e = { latched: m[2] === 'pressed', source: m[3], t: m[4] };
    }
    return e;
  }

  function renderEstop(e) {
    $('estop-state').hidden = !(e && e.latched);
    $('estop-state').textContent = e && e.latched ? `EMERGENCY STOP (${e.source}, ${e.t} s)` : '';
    document.body.dataset.estop = e && e.latched ? 'latched' : 'released';
  }

  function renderLines() {
    const T = viewTime();
    const lines = S.mode === 'replay' ? S.lines.filter((l) => l.t <= T).slice(-300) : S.lines;
    renderEstop(S.mode === 'replay' ? estopOf(S.lines.filter((l) => l.t <= T), null) : S.estop);
    const pre = $('lines');
    pre.textContent = lines.map((l) => `[${Number(l.t).toFixed(3)}] ${l.line}`).join('\n');
    pre.scrollTop = pre.scrollHeight;
  }

  $('config-set').addEventListener('submit', (ev) => {
    ev.preventDefault();
    command({ cmd: 'config_set', key: $('config-key').value, value: $('config-value').value });
  });
  // The run's abort: each running child of the root is aborted (an injected ABORTED, as the REPL's abort(path)),
  // so the root's expression ends ABORTED and the run with it.
  $('abort-all').addEventListener('click', () => {
    for (const [path, n] of S.nodes) {
      if (!S.nodes.has(n.parent) && S.kids.get(path)) {
        for (const k of S.kids.get(path)) if (stateOf(k).state === 'running') command({ cmd: 'abort', path: k });
      }
    }
  });

  // The robot's emergency stop (docs/safety.md): pressed, or released (a command that names it).
  $('estop').addEventListener('click', () => command({ cmd: 'estop' }));
  $('estop-release').addEventListener('click', () => command({ cmd: 'release', what: 'estop' }));

  // ------------------------------------------------------------------------------------------ robot (3D)

  // A URDF world's robot: its URDF and frames; its link frames subscribed to (live: samples; replay: the rows).
  function robot(m) {
    S.robot = { urdf: String(m.urdf || ''), frames: arr(m.frames), topic: m.topic, rows: [], shown: false };
    send(S.mode === 'live' ? { type: 'subscribe', topic: Number(m.topic), rate: 30 } : { type: 'subscribe', topic: m.topic });
    S.dirty.robot = true;
  }

  function robotRows(rows) {
    for (const r of rows) S.robot.rows.push(r);
    if (S.robot.rows.length > PLOT_KEEP) S.robot.rows.splice(0, S.robot.rows.length - PLOT_KEEP);
    S.dirty.robot = true;
  }

  // The frames at the view's time: live the last sample, replay the last row at or before the slider.
  function renderRobot() {
    const r3 = window.dcaRobot3d, R = S.robot;
    if (!r3 || !R) return;
    if (!R.shown) { R.shown = true; r3.show(R.urdf, R.frames); }
    const rows = R.rows;
    let row = rows[rows.length - 1];
    if (S.mode === 'replay') {
      row = undefined;
      for (const r of rows) { if (r[0] > S.viewT + 1e-9) break; row = r; }
    }
    if (row) r3.draw(row);
  }

  // ------------------------------------------------------------------------------------------ replay

  function viewTime() { return S.mode === 'replay' ? S.viewT : S.t; }

  function replayRange() {
    let t1 = S.t;
    for (const e of S.events) t1 = Math.max(t1, e.t);
    S.t = t1;
    $('slider').max = String(t1);
    sliderScale(t1);
    seek(0);
  }

  // The slider's scale: times under it, and a mark above it at each transition (at most one per pixel).
  function sliderScale(t1) {
    const span = Math.max(t1, 1e-3);
    let labels = '';
    for (let k = 0; k <= 5; k++) labels += `<span style="left:${k * 20}%">${(span * k / 5).toFixed(1)} s</span>`;
    $('slider-labels').innerHTML = labels;
    const seen = new Set();
    let marks = '';
    for (const e of S.events) {
      const at = Math.round(e.t / span * 400);
      if (seen.has(at)) continue;
      seen.add(at);
      marks += `<i style="left:${(e.t / span * 100).toFixed(2)}%" title="${esc(e.t.toFixed(3))} s: ${esc(e.path)} ${esc(e.state)}"></i>`;
    }
    $('slider-marks').innerHTML = marks;
  }

  function seek(T) {
    S.viewT = Math.max(0, Math.min(T, S.t));
    $('slider').value = String(S.viewT);
    const states = new Map();
    for (const e of S.events) {
      if (e.t > S.viewT) break;
      const prev = states.get(e.path) || {};
      states.set(e.path, { state: e.state, fault: e.fault || (e.state === 'running' ? '' : prev.fault) });
    }
    S.replayStates = states;
    S.dirty.states = true; S.dirty.timeline = true; S.dirty.plot = true; S.dirty.lines = true; S.dirty.robot = true;
  }

  $('slider').addEventListener('input', () => { S.playing = false; $('play').textContent = 'play'; seek(Number($('slider').value)); });
  $('play').addEventListener('click', () => {
    S.playing = !S.playing;
    if (S.playing && S.viewT >= S.t) seek(0);
    $('play').textContent = S.playing ? 'pause' : 'play';
  });

  // ------------------------------------------------------------------------------------------ pace
  // The simulated clock of a live run with a world (docs/time.md "Pace"): the world's time, paused or running
  // at a speed, from the snapshot's and deltas' `clock`; pause/go, one step, a step to the next event and the
  // speed are `clock` commands, which the root supervisor passes to the world, the clock master.

  function paceClock(c) {
    S.clock = { t: Number(c.t) || 0, running: !!c.running, speed: Number(c.speed) || 0, stepping: !!c.stepping };
    S.t = Math.max(S.t, S.clock.t);
    S.dirty.pace = true; S.dirty.timeline = true;
  }

  function renderPace() {
    const c = S.clock;
    $('pace').hidden = !(c && S.mode === 'live');
    if (!c) return;
    const paused = !c.running;
    $('pace-run').textContent = paused ? 'go' : 'pause';
    const sel = $('pace-speed');
    if (document.activeElement !== sel) sel.value = c.speed > 0 ? String(c.speed) : 'max';
    $('pace-state').textContent = paused ? 'paused' : (c.stepping ? 'stepping' : (c.speed > 0 ? `${c.speed}x` : 'max'));
    document.body.dataset.clock = paused ? 'paused' : 'running';
    document.body.dataset.clockT = c.t.toFixed(3);
    document.body.dataset.clockSpeed = c.speed > 0 ? String(c.speed) : 'max';
  }

  function paceCommand(what, speed) { command({ cmd: 'clock', what, speed }); }
  $('pace-run').addEventListener('click', () => paceCommand(S.clock && S.clock.running ? 'pause' : 'go'));
  $('pace-step').addEventListener('click', () => paceCommand('step'));
  $('pace-event').addEventListener('click', () => paceCommand('step_event'));
  $('pace-speed').addEventListener('change', () => {
    const v = $('pace-speed').value;
    paceCommand('speed', v === 'max' ? 'max' : Number(v));
  });

  // ------------------------------------------------------------------------------------------ connection

  function send(m) { if (S.ws && S.ws.readyState === 1) S.ws.send(JSON.stringify(m)); }
  function command(c) { send(Object.assign({ type: 'command', id: S.nextId++ }, c)); }

  function deny() {
    $('main').hidden = true;
    $('denied').hidden = false;
    document.body.dataset.access = 'denied';
    $('status').textContent = 'no access';
  }

  function onHello(m) {
    S.mode = m.mode === 'replay' ? 'replay' : 'live';
    $('system').textContent = m.name || '';
    $('main').hidden = false;
    $('replay').hidden = S.mode !== 'replay';
    for (const e of document.querySelectorAll('.live-only')) e.hidden = S.mode !== 'live';
    document.body.dataset.connected = 'yes';
    document.body.dataset.mode = S.mode;
    $('status').textContent = S.mode === 'replay' ? 'replay' : 'live';
    blackboxButton(S.mode === 'live' && m.blackbox === true);
  }

  // The black box button, shown when the run has one (dca run --blackbox): its file names `monitor: page`.
  function blackboxButton(shown) {
    const b = $('blackbox');
    b.hidden = !shown;
    b.onclick = shown ? () => command({ cmd: 'blackbox' }) : null;
  }

  function handle(m) {
    if (m.type === 'snapshot') snapshot(m);
    else if (m.type === 'delta') delta(m);
    else if (m.type === 'samples') samples(m);
    else if (m.type === 'series' && S.robot && String(m.topic) === String(S.robot.topic)) robotRows(arr(m.rows));
    else if (m.type === 'series') { if (plot.series(m)) S.dirty.plot = true; }
    else if (m.type === 'history') { if (plot.history(m)) S.dirty.plot = true; }
    else if (m.type === 'robot') robot(m);
    else if (m.type === 'reply') $('reply').textContent = `${m.ok ? 'ok' : 'refused'}: ${m.text || ''}`;
    else if (m.type === 'error') $('reply').textContent = 'error: ' + m.reason;
  }

  let everGreeted = false;
  function connect() {
    if (!token) { deny(); return; }
    let greeted = false;
    const ws = new WebSocket(`ws://${location.host}/ws?token=${encodeURIComponent(token)}`, 'dca.monitor.v1');
    S.ws = ws;
    ws.onmessage = (ev) => {
      let m;
      try { m = JSON.parse(ev.data); } catch (e) { return; }
      if (m.type === 'hello') { greeted = everGreeted = true; S.ended = false; onHello(m); } else handle(m);
    };
    ws.onclose = () => {
      document.body.dataset.connected = 'no';
      S.ended = true; S.dirty.plot = true;  // (the plot keeps what it has, and says why nothing more comes)
      if (!greeted && !everGreeted) { deny(); return; }
      $('status').textContent = S.mode === 'replay' ? 'replay (server gone)' : 'disconnected';
      if (S.mode === 'live') setTimeout(connect, 2000);
    };
  }

  // ------------------------------------------------------------------------------------------ the frame loop

  let lastFrame = 0, lastTimeline = 0;
  function frame(now) {
    if (S.playing) {
      const speed = Number($('speed').value) || 1;
      seek(S.viewT + Math.min(0.1, (now - lastFrame) / 1000) * speed);
      if (S.viewT >= S.t) { S.playing = false; $('play').textContent = 'play'; }
    }
    lastFrame = now;
    const d = S.dirty;
    $('clock').textContent = viewTime().toFixed(3);
    if (d.tree) { d.tree = false; renderTree(); d.exprs = true; }
    if (d.exprs) { d.exprs = false; renderExprs(); }
    if (d.states) { d.states = false; renderStates(); }
    if (d.timeline && now - lastTimeline > 150) { d.timeline = false; lastTimeline = now; renderTimeline(); }
    if (d.plot) { d.plot = false; renderPlot(); }
    if (d.config) { d.config = false; renderConfig(); }
    if (d.lines) { d.lines = false; renderLines(); }
    if (d.rt) { d.rt = false; renderRt(); }
    if (d.robot) { d.robot = false; renderRobot(); }
    if (d.pace) { d.pace = false; renderPace(); }
    requestAnimationFrame(frame);
  }

  function esc(s) {
    return String(s === undefined || s === null ? '' : s).replace(/[&<>"']/g,
      (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' }[c]));
  }

  window.dcaMonitor = S;  // for tests and the curious
  connect();
  requestAnimationFrame(frame);
})();
