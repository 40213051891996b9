/* fg_tea episode explorer (docs/design.md §9.2).
 *
 * Draws the page data embedded in this file: one episode, or two episodes of the same world side
 * by side. Plain JavaScript, no libraries, no network. The static parts of each pane (the house,
 * the task graph, the chart lines) are built once; a step change only updates fills, texts,
 * classes and cursors, synchronously, so `explorer.go(i)` can be followed by reading the DOM.
 *
 * User-facing step numbers are 1-based ("step 7 / 62"); the data's step indices are 0-based.
 */
(function () {
  'use strict';

  const SVGNS = 'http://www.w3.org/2000/svg';
  const S = 50;   // floor plan: SVG units per metre
  const M = 24;   // floor plan: margin around the floor, SVG units
  const PALETTE = ['#1f77b4', '#d62728', '#2ca02c', '#ff7f0e', '#9467bd',
                   '#8c564b', '#e377c2', '#17becf', '#7f7f7f', '#bcbd22'];
  const LETTERS = ['A', 'B'];

  let data = null;        // the page data
  let pairs = [];         // slider positions: [step of pane 0, step of pane 1?]
  let cur = -1;           // current index into pairs
  let object = null;      // object whose location belief shades the sites
  let pinned = false;     // the user chose the object; until then it follows the decision in force
  let objects = [];       // union of the episodes' objects
  let panes = [];         // one per episode, see buildPane
  let decisionPairs = []; // pair indices where some pane reaches a decision (PageUp / PageDown)
  let video = null;
  let videoTime = null;   // the time the video should show once its metadata is loaded
  let entropyMax = 1;     // top of the entropy charts' axis, shared by the panes
  const colourOf = {};    // series name (object or state) -> colour
  const $ = (id) => document.getElementById(id);

  // ---------------------------------------------------------------------------------- helpers
  function setAttrs(e, attrs) {
    for (const k in attrs) if (attrs[k] !== null && attrs[k] !== undefined) e.setAttribute(k, attrs[k]);
    return e;
  }
  function make(e, attrs, parent, text) {
    setAttrs(e, attrs || {});
    if (text !== undefined && text !== null) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }
  /** An HTML (h) or SVG (s) element with attributes, appended to parent, with optional text. */
  const h = (tag, attrs, parent, text) => make(document.createElement(tag), attrs, parent, text);
  const s = (tag, attrs, parent, text) => make(document.createElementNS(SVGNS, tag), attrs, parent, text);
  /** A value as a number: "inf" / "-inf" (unreachable distances) become infinities. */
  function num(v) {
    if (v === 'inf') return Infinity;
    if (v === '-inf') return -Infinity;
    return typeof v === 'number' ? v : NaN;
  }
  /** A table cell: integers as is, other numbers with 3 decimals, ∞ for "inf", strings as is. */
  function fmt(v) {
    if (v === null || v === undefined) return '–';
    if (v === 'inf') return '∞';
    if (v === '-inf') return '−∞';
    if (typeof v === 'number') return Number.isInteger(v) ? String(v) : v.toFixed(3);
    if (typeof v === 'object') return JSON.stringify(v);
    return String(v);
  }
  /** A probability with exactly 3 decimals ('–' when unknown). */
  const fmtP = (p) => (typeof p === 'number' && isFinite(p) ? p.toFixed(3) : '–');
  /** Run fn after the next frame has been rendered (safe()-wrapped). */
  const afterFrame = (fn) => requestAnimationFrame(() => setTimeout(() => safe(fn), 0));
  const pretty = (name) => String(name).replace(/_/g, ' ');
  const clamp = (x, lo, hi) => Math.max(lo, Math.min(hi, x));

  /** Site shade: white -> mid blue -> dark blue on sqrt(p), so that small probabilities show. */
  const RAMP = [[255, 255, 255], [107, 174, 214], [8, 48, 107]];
  function ramp(p) {
    if (typeof p !== 'number' || !isFinite(p)) return '#e4e4e4';
    const t = Math.sqrt(clamp(p, 0, 1)) * 2;
    const [a, b] = t < 1 ? [RAMP[0], RAMP[1]] : [RAMP[1], RAMP[2]];
    const f = t < 1 ? t : t - 1;
    return 'rgb(' + a.map((c, i) => Math.round(c + (b[i] - c) * f)).join(',') + ')';
  }

  function showError(err) {
    console.error(err);
    $('error').hidden = false;
    $('error').textContent = 'The explorer failed: ' + ((err && err.message) || String(err));
  }
  function notice(text, cls) {
    const list = $('notices');
    h('li', {class: cls || null}, list, text);
    list.hidden = false;
  }

  // ----------------------------------------------------------------------------------- header
  function buildHeader() {
    const info = $('episodes-info');
    data.episodes.forEach((ep, i) => {
      const row = h('div', {class: 'episode-info', 'data-episode': i}, info);
      if (data.episodes.length > 1) h('b', {class: 'letter'}, row, LETTERS[i]);
      h('span', {class: 'label'}, row, ep.label);
      const model = ep.model + (ep.structure && ep.structure !== ep.model ? ' (' + ep.structure + ')' : '');
      const facts = [['scenario', ep.scenario], ['model', model], ['planner', ep.planner], ['task', ep.task],
                     ['seed', ep.seed], ['log', ep.log]];
      for (const [k, v] of facts) {
        if (v === null || v === undefined) continue;
        const f = h('span', {class: 'fact'}, row, k + ' ');
        h('b', null, f, String(v));
      }
      h('span', {class: 'outcome', 'data-outcome': ep.outcome || 'none'}, row,
        ep.outcome ? 'outcome: ' + ep.outcome : 'no outcome (the log stops early)');
    });
    h('div', {class: 'page-version'}, info,
      'page data format ' + data.format + ' · fg_tea ' + (data.fg_tea || '?'));
  }

  function buildNotices() {
    if (data.format !== 1) {
      notice('This page data has format ' + data.format + '; this explorer was written for format 1, ' +
             'so parts of the page may be wrong or missing.', 'warning');
    }
    if (data.house && data.house.missing) notice(data.house.missing);
    data.episodes.forEach((ep, i) => {
      const who = data.episodes.length > 1 ? LETTERS[i] + ' (' + ep.label + ')' : ep.label;
      for (const lack of ep.lacks || []) notice(who + ' lacks ' + lack);
    });
  }

  // --------------------------------------------------------------------------------- controls
  function buildControls() {
    const slider = $('step-slider');
    slider.max = String(pairs.length - 1);
    slider.addEventListener('input', () => safe(() => go(Number(slider.value))));
    $('prev').addEventListener('click', () => safe(() => go(cur - 1)));
    $('next').addEventListener('click', () => safe(() => go(cur + 1)));

    const select = $('object');
    for (const o of objects) h('option', {value: o}, select, o);
    select.value = object;
    select.addEventListener('change', () => safe(() => { pinned = true; setObject(select.value); }));

    // The step keys work wherever the focus is (the slider's and the object list's own handling of
    // them is overridden; the list keeps ArrowUp / ArrowDown), except in a text field.
    document.addEventListener('keydown', (e) => {
      const t = e.target;
      if (e.altKey || e.ctrlKey || e.metaKey) return;
      if (t && (t.tagName === 'TEXTAREA' || t.isContentEditable || (t.tagName === 'INPUT' && t.type !== 'range'))) return;
      const moves = {
        ArrowLeft: () => cur - 1, ArrowRight: () => cur + 1, Home: () => 0, End: () => pairs.length - 1,
        PageUp: () => { const d = decisionPairs.filter((i) => i < cur); return d.length ? d[d.length - 1] : 0; },
        PageDown: () => { const d = decisionPairs.find((i) => i > cur); return d === undefined ? cur : d; },
      };
      if (!moves[e.key]) return;
      e.preventDefault(); // the slider would otherwise move too (PageUp/Down by 10 %)
      safe(() => go(moves[e.key]()));
    });
  }

  /** Run an event handler, showing any error on the page instead of losing it. */
  function safe(fn) {
    try { fn(); } catch (err) { showError(err); }
  }

  // ------------------------------------------------------------------------------- divergence
  function buildDivergence() {
    const box = $('divergence');
    if (data.episodes.length < 2) return;
    box.hidden = false;
    const div = data.divergence;
    if (!div) {
      h('p', {class: 'same'}, box, 'The two episodes made the same choices at every decision.');
      return;
    }
    box.dataset.decision = String(div.decision);
    const says = (side, name) => side
      ? name + ' looks for the ' + side.object + ' from ' + side.viewpoint
      : name + ' made no further decision';
    h('p', {class: 'headline'}, box, 'Choices differ first at decision ' + (div.decision + 1) + ': ' +
      says(div.a, 'A') + ', ' + says(div.b, 'B') + '.');
    const beliefs = h('div', {class: 'beliefs'}, box);
    [div.a, div.b].forEach((side, i) => {
      if (!side) return;
      const ep = data.episodes[i];
      const col = h('div', {class: 'belief', 'data-episode': i}, beliefs);
      h('div', {class: 'belief-title'}, col, LETTERS[i] + ' (' + ep.label + '), belief over sites for the ' +
        side.object + ' before step ' + (side.step + 1) + ' (top 5):');
      const top = (side.belief || []).map((p, k) => [ep.sites[k], p])
        .sort((x, y) => y[1] - x[1]).slice(0, 5);
      const list = h('ol', null, col);
      for (const [site, p] of top) {
        const li = h('li', {'data-site': site}, list, site + ': ');
        h('span', {class: 'p'}, li, fmtP(p));
      }
    });
    const button = h('button', {id: 'goto-divergence', type: 'button'}, box, 'go to the divergence');
    if (div.pair === null || div.pair === undefined) button.disabled = true;
    button.addEventListener('click', () => safe(() => go(div.pair)));
  }

  // ------------------------------------------------------------------------------------ video
  function buildVideo() {
    if (!data.video || !data.video.src) return;
    const box = $('shared');
    box.hidden = false;
    h('h2', null, box, data.episodes.length > 1 ? 'Video of episode A' : 'Video');
    video = h('video', {id: 'video', controls: '', muted: '', preload: 'metadata'}, box);
    video.muted = true;
    let failed = false;
    const fail = () => {
      if (failed) return;
      failed = true;
      video.hidden = true;
      notice('video ' + data.video.src + ' could not be loaded', 'warning');
    };
    video.addEventListener('error', fail);
    video.addEventListener('loadedmetadata', () => {
      if (videoTime !== null) video.currentTime = videoTime;
    });
    if (data.video.note) notice(data.video.note, 'warning');
    video.src = data.video.src; // after the listeners, so that an early failure is caught
  }

  function syncVideo() {
    if (!video || video.hidden) return;
    const t = (data.video.times || [])[pairs[cur][0]];
    if (typeof t !== 'number' || !isFinite(t)) return;
    videoTime = t;
    if (!video.paused) video.pause();
    if (video.readyState >= 1) video.currentTime = t; // HAVE_METADATA; otherwise on loadedmetadata
  }

  // ------------------------------------------------------------------------------------- pane
  function buildPane(ep, i) {
    const two = data.episodes.length > 1;
    const el = h('section', {class: 'pane', 'data-episode': i}, $('panes'));
    const title = h('h2', null, el);
    if (two) h('span', {class: 'letter'}, title, LETTERS[i]);
    h('span', null, title, ep.label);
    const cap = h('div', {class: 'caption'}, el);
    // Spaces between the parts keep the caption's textContent readable ("decision decide: …").
    const part = (cls) => { if (cap.firstChild) cap.append(' '); return h('span', {class: cls}, cap); };
    const pane = {i, ep, el, siteIdx: {}, inForce: [], pairOfStep: [],
                  caption: {event: part('event'), text: part('text'), where: part('where')}};
    ep.sites.forEach((name, k) => { pane.siteIdx[name] = k; });
    // The decision in force at each step: the latest decision at or before it.
    let d = null;
    ep.steps.forEach((st, k) => {
      if (st.decision !== null && st.decision !== undefined) d = st.decision;
      pane.inForce[k] = d;
    });
    // The first slider position showing each step of this episode (for clicks on the charts).
    pairs.forEach((pr, k) => {
      const st = stepOf(pr, i);
      if (pane.pairOfStep[st] === undefined) pane.pairOfStep[st] = k;
    });

    const body = h('div', {class: 'pane-body'}, el);
    const colPlan = h('div', {class: 'col-plan'}, body);
    const colInfo = h('div', {class: 'col-info'}, body);
    buildPlan(pane, colPlan);
    pane.historyHost = colPlan;
    buildCandidates(pane, colInfo);
    buildMoved(pane, colInfo);
    buildStates(pane, colInfo);
    const wide = h('div', {class: 'col-wide'}, body);
    buildTasks(pane, wide);
    const charts = h('div', {class: 'charts'}, wide);
    buildCharts(pane, charts);
    return pane;
  }

  /** The step of episode `i` shown at slider position `pr` (held at the last step if missing). */
  function stepOf(pr, i) {
    const n = data.episodes[i].steps.length;
    const st = pr[i] !== undefined ? pr[i] : pr[pr.length - 1];
    return clamp(st | 0, 0, n - 1);
  }

  /** Move the slider to the first position that shows `step` in this pane (or the nearest). */
  function goToStep(pane, step) {
    let best = null;
    let gap = Infinity;
    pane.pairOfStep.forEach((k, st) => {
      if (k !== undefined && Math.abs(st - step) < gap) { gap = Math.abs(st - step); best = k; }
    });
    if (best !== null) go(best);
  }

  function drawPane(pane, k) {
    const st = pane.ep.steps[k];
    pane.caption.event.textContent = st.event;
    pane.caption.text.textContent = st.caption;
    pane.caption.where.textContent = 'step ' + (k + 1) + ' of ' + pane.ep.steps.length + ' · event ' + st.seq;
    drawPlan(pane, st);
    drawCandidates(pane, pane.inForce[k]);
    drawMoved(pane, k);
    drawStates(pane, k);
    drawTasks(pane, st);
    for (const c of pane.charts) c.move(k);
    if (pane.history) drawHistory(pane, k);
  }

  // ------------------------------------------------------------------------------- floor plan
  function buildPlan(pane, parent) {
    const house = data.house;
    const [x0, y0, x1, y1] = house.floor;
    const X = (x) => +((x - x0) * S + M).toFixed(1);
    const Y = (y) => +((y1 - y) * S + M).toFixed(1); // world y runs up, SVG y down
    const W = (x1 - x0) * S + 2 * M;
    const H = (y1 - y0) * S + 2 * M;
    const svg = s('svg', {class: 'plan', viewBox: '0 0 ' + W + ' ' + H, role: 'img',
                          'aria-label': 'floor plan of ' + (pane.ep.scenario || 'the house')}, parent);
    const plan = pane.plan = {X, Y, sites: {}, vps: {}};
    s('rect', {class: 'floor', x: M, y: M, width: (x1 - x0) * S, height: (y1 - y0) * S}, svg);
    const gFurn = s('g', {class: 'furniture'}, svg);
    for (const [fx, fy, fw, fh, colour] of house.furniture || []) {
      s('rect', {x: X(fx), y: Y(fy + fh), width: fw * S, height: fh * S, fill: colour, stroke: colour}, gFurn);
    }
    const gWalls = s('g', {class: 'walls'}, svg);
    for (const wall of house.walls || []) {
      s('polygon', {points: wall.map(([x, y]) => X(x) + ',' + Y(y)).join(' ')}, gWalls);
    }
    const gRooms = s('g', {class: 'rooms'}, svg);
    fitRoomLabels((house.rooms || []).map((room) =>
      s('text', {x: X(room.centre[0]), y: Y(room.centre[1]), 'text-anchor': 'middle'}, gRooms, pretty(room.name))));
    plan.look = s('g', {class: 'look'}, svg);
    // The path walked so far: a prefix of the episode's path points.
    plan.points = (pane.ep.path || []).map(([x, y]) => X(x) + ',' + Y(y));
    plan.path = s('polyline', {class: 'path', points: ''}, svg);
    const gVant = s('g', {class: 'vantages'}, svg);
    const vantageOf = {};
    for (const site of house.sites) {
      if (!site.vantage) continue;
      vantageOf[site.name] = s('circle', {class: 'vantage', cx: X(site.vantage[0]), cy: Y(site.vantage[1]), r: 3,
                                          'data-site': site.name}, gVant);
      s('title', null, vantageOf[site.name], 'vantage of ' + site.name);
    }
    const gVp = s('g', {class: 'viewpoints'}, svg);
    for (const vp of house.viewpoints || []) {
      const [cx, cy] = [X(vp.position[0]), Y(vp.position[1])];
      let mark = vp.kind === 'site' ? vantageOf[vp.name] : null;
      if (!mark) {
        mark = vp.kind === 'room'
          ? s('path', {class: 'viewpoint room', d: 'M' + cx + ',' + (cy - 8) + 'l8,8l-8,8l-8,-8z'}, gVp)
          : s('circle', {class: 'viewpoint', cx, cy, r: 3}, gVp);
        s('title', null, mark, vp.name + ' (' + vp.kind + ' viewpoint: ' + vp.sites.join(', ') + ')');
      }
      mark.setAttribute('data-viewpoint', vp.name);
      plan.vps[vp.name] = {x: cx, y: cy, el: mark};
    }
    plan.lookMark = s('circle', {class: 'look-vp', r: 11, cx: -100, cy: -100}, svg);
    const gSites = s('g', {class: 'sites'}, svg);
    for (const site of house.sites) {
      const [cx, cy] = [X(site.position[0]), Y(site.position[1])];
      const g = s('g', {class: 'site-g'}, gSites);
      const circle = s('circle', {class: 'site', 'data-site': site.name, cx, cy, r: 10}, g);
      s('title', null, circle, site.name + (site.room ? ' (' + site.room + ')' : '') + ': click for its history');
      // Labels (probability, then short name) go on the side of the site facing its vantage:
      // into the room, away from the wall. `u` is that direction in SVG coordinates.
      const to = site.vantage || (house.rooms.find((r) => r.name === site.room) || {}).centre || site.position;
      const dx = to[0] - site.position[0];
      const dy = site.position[1] - to[1];
      const u = Math.abs(dx) > Math.abs(dy) ? [Math.sign(dx) || 1, 0] : [0, Math.sign(dy) || 1];
      const anchor = u[0] > 0 ? 'start' : u[0] < 0 ? 'end' : 'middle';
      const at = u[0] ? [cx + 14 * u[0], cy - 1] : [cx, u[1] > 0 ? cy + 23 : cy - 14];
      const block = s('g', {class: 'site-label', transform: 'translate(' + at + ')'}, g);
      // The site's own name, as the candidate table and the log write it (never shortened).
      const text = s('text', {class: 'site-p', 'data-site': site.name, x: 0, y: 0, 'text-anchor': anchor},
                     block, '0.000');
      s('text', {class: 'site-name', x: 0, y: u[1] < 0 ? -12 : 11, 'text-anchor': anchor}, block, pretty(site.name));
      // Objects found here are written above the site (labels beside it) or beside it (labels below/above).
      const found = u[0] ? {x: cx, y: cy - 15, anchor: 'middle'} : {x: cx + 13, y: cy + 4, anchor: 'start'};
      g.addEventListener('click', () => safe(() => openHistory(pane, site.name)));
      plan.sites[site.name] = {circle, text, block, at, u, found, x: cx, y: cy, covered: false, fill: null};
    }
    placeLabels(plan);
    plan.found = s('g', {class: 'found-layer'}, svg);
    plan.truth = s('g', {class: 'truth'}, svg);
    plan.agent = s('polygon', {class: 'agent', points: '13,0 -8,-7.5 -4,0 -8,7.5'}, svg);
    s('title', null, plan.agent, 'the agent');
    const missing = pane.ep.sites.filter((n) => !plan.sites[n]);
    if (missing.length) {
      notice(pane.ep.label + ': ' + missing.length + ' site(s) have no position and are not drawn: ' + missing.join(', '));
    }

    const legend = h('div', {class: 'legend plan-legend'}, parent);
    pane.legendObject = h('span', {class: 'ramp-label'}, legend, '');
    h('span', {class: 'ramp'}, legend);
    h('span', {class: 'ramp-ticks'}, legend, '0 · 0.25 · 1 (shade ∝ √p)');
    for (const [key, text] of [['covered', 'in view'], ['agent', 'agent'], ['room', 'room viewpoint'],
                               ['vantage', 'vantage'], ['truth', 'true place']]) {
      h('span', {class: 'key ' + key + '-key'}, legend, text);
    }
  }

  /** Room names that would overlap another (two rooms whose centres are close: "DINING ROOM"
   *  beside "LIVING ROOM") go on two lines, then smaller, then apart vertically, until none does. */
  function fitRoomLabels(texts) {
    const meet = (a, b) => a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height && b.y < a.y + a.height;
    const clashing = () => texts.filter((t) => texts.some((o) => o !== t && meet(t.getBBox(), o.getBBox())));
    for (const t of clashing()) {
      const words = t.textContent.split(' ');
      if (words.length < 2) continue;
      const x = t.getAttribute('x');
      t.textContent = '';
      words.forEach((w, j) => s('tspan', {x, dy: (j ? 1.05 : -0.525 * (words.length - 1)) + 'em'}, t,
                                w + (j < words.length - 1 ? ' ' : '')));
    }
    for (let size = 15; size >= 10 && clashing().length; size--) {
      for (const t of clashing()) t.style.fontSize = size + 'px';
    }
    for (let round = 0; round < 8; round++) { // still clashing: move the later label down
      const bad = clashing();
      if (!bad.length) break;
      const t = bad[bad.length - 1];
      const other = bad.find((o) => o !== t && meet(t.getBBox(), o.getBBox())) || t;
      const shift = other.getBBox().y + other.getBBox().height - t.getBBox().y + 2;
      t.setAttribute('y', +t.getAttribute('y') + shift);
    }
  }

  /** Nudge site label blocks that would overlap an earlier label or a site circle: try a few
   *  offsets along and across the label's direction; keep the first free one (or none). */
  function placeLabels(plan) {
    const placed = Object.values(plan.sites).map((x) => ({x: x.x - 11, y: x.y - 11, w: 22, h: 22}));
    const hits = (r) => placed.some((q) => r.x < q.x + q.w && q.x < r.x + r.w && r.y < q.y + q.h && q.y < r.y + r.h);
    for (const site of Object.values(plan.sites)) {
      const b = site.block.getBBox();
      const [ux, uy] = site.u;
      const tries = ux ? [[0, 0], [0, -13], [0, 13], [16 * ux, 0], [0, -26], [0, 26]]
        : [[0, 0], [0, 24 * uy], [28, 0], [-28, 0], [28, 24 * uy], [-28, 24 * uy], [0, 48 * uy]];
      // (shrunk by 2 units: text boxes vary by a unit or so with the rendered size)
      const box = ([ox, oy]) => ({x: site.at[0] + ox + b.x + 2, y: site.at[1] + oy + b.y + 2,
                                  w: b.width - 4, h: b.height - 4});
      const best = tries.find((o) => !hits(box(o))) || tries[0];
      if (best !== tries[0]) {
        site.block.setAttribute('transform', 'translate(' + (site.at[0] + best[0]) + ',' + (site.at[1] + best[1]) + ')');
      }
      placed.push(box(best));
    }
  }

  function drawPlan(pane, st) {
    const plan = pane.plan;
    const locs = (st.locations || {})[object];
    const look = st.look || {sites: []};
    const covered = new Set(look.sites || []);
    for (const name in plan.sites) {
      const site = plan.sites[name];
      const k = pane.siteIdx[name];
      const p = locs && k !== undefined ? locs[k] : null;
      const fill = ramp(p);
      if (fill !== site.fill) { site.circle.setAttribute('fill', fill); site.fill = fill; }
      site.text.textContent = fmtP(p);
      const c = covered.has(name);
      if (c !== site.covered) { site.circle.classList.toggle('covered', c); site.covered = c; }
    }
    plan.path.setAttribute('points', plan.points.slice(0, st.path || 0).join(' '));
    const [ax, ay, yaw] = st.pose || [0, 0, 0];
    plan.agent.setAttribute('transform', 'translate(' + plan.X(ax) + ',' + plan.Y(ay) + ') rotate(' + (-yaw) + ')');

    // The look in force: the viewpoint ringed, a line to every site in view.
    plan.look.textContent = '';
    if (plan.current) { plan.current.classList.remove('current'); plan.current = null; }
    if (look.viewpoint) {
      let vp = plan.vps[look.viewpoint];
      if (!vp) { // an older log: no viewpoints, the look is a close look at its site
        const site = data.house.sites.find((x) => x.name === look.viewpoint);
        const at = site ? (site.vantage || site.position) : null;
        vp = at ? {x: plan.X(at[0]), y: plan.Y(at[1]), el: null} : null;
      }
      if (vp) {
        setAttrs(plan.lookMark, {cx: vp.x, cy: vp.y});
        if (vp.el) { vp.el.classList.add('current'); plan.current = vp.el; }
        for (const name of covered) {
          const site = plan.sites[name];
          if (site) s('line', {class: 'look-line', x1: vp.x, y1: vp.y, x2: site.x, y2: site.y}, plan.look);
        }
      }
    } else {
      setAttrs(plan.lookMark, {cx: -100, cy: -100});
    }

    // Objects detected at this step: "✓ mug, kettle" beside the site they were found on.
    plan.found.textContent = '';
    const det = st.detections;
    if (det && det.seen) {
      const at = {};
      for (const obj in det.seen) {
        const name = (det.found_at || {})[obj] || (look.sites || [])[0];
        if (det.seen[obj] && plan.sites[name]) (at[name] = at[name] || []).push(obj);
      }
      for (const name in at) {
        const f = plan.sites[name].found;
        const t = s('text', {class: 'found', 'data-site': name, 'data-objects': at[name].join(' '),
                             x: f.x, y: f.y, 'text-anchor': f.anchor}, plan.found, '✓ ');
        at[name].forEach((obj, j) => {
          if (j) t.append(', ');
          s('tspan', {class: 'found-object', 'data-object': obj, fill: colourOf[obj]}, t, obj);
        });
      }
    }
    drawTruth(pane);
  }

  /** A cross where the selected object really is (the world's placement), if the log records it. */
  function drawTruth(pane) {
    const plan = pane.plan;
    const at = (pane.ep.placements || {})[object];
    if (plan.truthFor === object) return;
    plan.truthFor = object;
    plan.truth.textContent = '';
    pane.legendObject.textContent = 'P(' + object + ' was on this site at the start): ';
    if (!at) return;
    const [x, y] = [plan.X(at[0]), plan.Y(at[1])];
    const cross = s('path', {class: 'truth-mark', d: 'M' + (x - 5) + ',' + (y - 5) + 'l10,10m0,-10l-10,10'}, plan.truth);
    s('title', null, cross, 'where the ' + object + ' really is');
  }

  // ----------------------------------------------------------------------------- site history
  function openHistory(pane, name) {
    closeHistory(pane);
    const ep = pane.ep;
    const k = pane.siteIdx[name];
    const site = data.house.sites.find((x) => x.name === name) || {};
    const box = h('div', {class: 'site-history', 'data-site': name}, pane.historyHost);
    const head = h('div', {class: 'history-head'}, box);
    h('b', null, head, name);
    h('span', null, head, (site.room ? ' (' + site.room + ')' : '') +
      ': belief that each object stood here at the start, over the steps (0 to 1)');
    const close = h('button', {class: 'close', type: 'button', 'aria-label': 'close', title: 'close'}, head, '×');
    close.addEventListener('click', () => closeHistory(pane));
    const rows = [];
    const n = ep.steps.length;
    const W = 240, Hh = 34;
    const x = (i) => +(2 + (n > 1 ? i / (n - 1) : 0) * (W - 4)).toFixed(1);
    for (const obj of ep.objects) {
      const row = h('div', {class: 'history-row', 'data-object': obj}, box);
      const label = h('span', {class: 'obj'}, row, obj);
      label.style.borderColor = colourOf[obj];
      const svg = s('svg', {class: 'spark', viewBox: '0 0 ' + W + ' ' + Hh, preserveAspectRatio: 'none'}, row);
      s('line', {class: 'axis', x1: 0, x2: W, y1: Hh - 2, y2: Hh - 2}, svg);
      const pts = ep.steps.map((st, i) => {
        const p = k === undefined ? null : ((st.locations || {})[obj] || [])[k];
        return typeof p === 'number' ? x(i) + ',' + (2 + (1 - p) * (Hh - 4)).toFixed(1) : null;
      }).filter((p) => p !== null);
      s('polyline', {points: pts.join(' '), stroke: colourOf[obj]}, svg);
      const cursor = s('line', {class: 'cursor', y1: 0, y2: Hh}, svg);
      const value = h('span', {class: 'value', 'data-object': obj}, row, '');
      rows.push({obj, cursor, value, x});
    }
    pane.history = {name, k, el: box, rows};
    drawHistory(pane, stepOf(pairs[cur], pane.i));
  }

  function closeHistory(pane) {
    if (pane.history) pane.history.el.remove();
    pane.history = null;
  }

  function drawHistory(pane, k) {
    const hist = pane.history;
    const st = pane.ep.steps[k];
    for (const row of hist.rows) {
      setAttrs(row.cursor, {x1: row.x(k), x2: row.x(k)});
      const p = hist.k === undefined ? null : ((st.locations || {})[row.obj] || [])[hist.k];
      row.value.textContent = fmtP(p);
    }
  }

  // ------------------------------------------------------------------------- candidate table
  function buildCandidates(pane, parent) {
    h('h3', null, parent, 'Decision in force');
    const head = h('div', {class: 'decision-head'}, parent);
    const wrap = h('div', {class: 'table-wrap candidates-wrap'}, parent);
    const note = h('p', {class: 'note'}, wrap, '');
    pane.cand = {head, wrap, note, shown: undefined, sort: null, table: null, built: {}};
  }

  function drawCandidates(pane, k) {
    const cand = pane.cand;
    if (cand.shown === k) return; // redrawn only when the decision in force changes
    cand.shown = k;
    // Tables are built on first show and then kept in the box, the others parked with
    // content-visibility: hidden (class `parked`), which keeps their layout: a 180-row table costs
    // ~20 ms to lay out afresh, under 1 ms to show again. Only the shown one has class `candidates`.
    if (cand.table) {
      cand.table.box.classList.add('parked');
      cand.table.el.setAttribute('class', 'candidates-parked');
      cand.table = null;
    }
    const decisions = pane.ep.decisions;
    const d = k === null || k === undefined ? null : decisions[k];
    cand.note.hidden = !!(d && d.rows && d.rows.length);
    if (!d) {
      cand.head.textContent = 'no decision yet';
      cand.note.textContent = 'the candidates appear with the first decision';
      return;
    }
    cand.head.textContent = 'decision ' + (k + 1) + ' of ' + decisions.length + ' at step ' + (d.step + 1) +
      ' (event ' + d.seq + ')' + (d.planner ? ' · ' + d.planner : '') +
      (d.serving ? ' · serving ' + d.serving : '') + ': look for the ' + d.object + ' from ' + d.viewpoint +
      (d.total !== null && d.total !== undefined ? ' (total ' + fmt(d.total) + ')' : '') +
      '; the lowest total is chosen' + weights(d.info) + serves(d);
    if (!d.rows || !d.rows.length) {
      cand.note.textContent = 'no candidates logged for this decision';
      return;
    }
    const table = cand.built[k] || (cand.built[k] = buildCandidateTable(pane, d, k));
    if (!table.box.parentNode) cand.wrap.appendChild(table.box);
    table.box.classList.remove('parked');
    table.el.setAttribute('class', 'candidates');
    cand.table = table;
    sortCandidates(pane);
    // Bring the chosen row into view inside the table's own scroll box once this step has been
    // rendered: reading offsetTop now would force a layout inside the step change, and doing it
    // before the frame (in requestAnimationFrame) makes Chromium lay out the just-parked table.
    const chosen = table.trs[d.chosen];
    afterFrame(() => {
      if (cand.table !== table) return;
      cand.wrap.scrollTop = chosen ? Math.max(0, chosen.offsetTop - cand.wrap.clientHeight / 3) : 0;
    });
  }

  /** The decision's score weights as logged (docs/design.md eq. 17), for recomputing a total. */
  function weights(info) {
    if (!info || typeof info !== 'object') return '';
    const parts = Object.keys(info).filter((key) => typeof info[key] === 'number' && /^(w_|lambda)/.test(key))
      .map((key) => key + ' ' + info[key]);
    return parts.length ? ' · weights: ' + parts.join(', ') : '';
  }

  /** When one look serves the searches of several objects, say so (docs/design.md §6.1). */
  function serves(d) {
    const objs = Array.isArray(d.objects) ? d.objects.map(String) : [];
    if (objs.length < 2) return '';
    return ' · this SEARCH serves ' + objs.length + ' objects (' + objs.join(', ') + '): the look updates ' +
      'each one\'s belief, and every object it finds has its search confirmed';
  }

  function buildCandidateTable(pane, d, k) {
    const box = h('div', {class: 'cand-box'});
    const el = h('table', {class: 'candidates', 'data-decision': k}, box);
    const tr = h('tr', null, h('thead', null, el));
    const ths = d.columns.map((col) => {
      const th = h('th', {scope: 'col', 'data-col': col, 'aria-sort': 'none', title: 'sort by ' + col}, tr);
      // Long names may wrap after an underscore (<wbr> adds no text: th.textContent stays the name).
      String(col).split('_').forEach((part, j) => {
        if (j) { th.append('_'); h('wbr', null, th); }
        th.append(part);
      });
      th.addEventListener('click', () => safe(() => {
        const sort = pane.cand.sort;
        pane.cand.sort = {col, dir: sort && sort.col === col ? -sort.dir : 1};
        sortCandidates(pane);
        pane.cand.wrap.scrollTop = 0;
      }));
      return th;
    });
    const tbody = h('tbody', null, el);
    const trs = d.rows.map((row, i) => {
      const r = h('tr', {'data-row': i, class: i === d.chosen ? 'chosen' : null}, tbody);
      if (i === d.chosen) r.title = 'the chosen candidate';
      row.forEach((v, j) => {
        const td = h('td', {class: isNaN(num(v)) ? 'str' : 'num'}, r);
        // A long name (a viewpoint) may wrap after an underscore, so the table fits a narrow pane.
        String(fmt(v)).split('_').forEach((part, m) => {
          if (m) { td.append('_'); h('wbr', null, td); }
          td.append(part);
        });
        // The raw value too, as data-<column> (e.g. data-total="-1.575", data-distance="inf").
        if (/^[a-z][a-z0-9_]*$/i.test(d.columns[j])) r.setAttribute('data-' + d.columns[j], v === null ? '' : String(v));
      });
      return r;
    });
    return {box, el, ths, tbody, trs, d, order: '-1:0'}; // rows in the given order
  }

  /** Build and lay out the decisions' tables ahead of time, one per idle moment, and park them,
   *  so that even the first visit to a decision redraws quickly. */
  function warmTables() {
    const todo = [];
    for (const pane of panes) {
      pane.ep.decisions.forEach((d, k) => { if (d.rows && d.rows.length) todo.push([pane, k]); });
    }
    const later = (fn) => (window.requestIdleCallback ? requestIdleCallback(fn, {timeout: 1000}) : setTimeout(fn, 30));
    const next = () => safe(() => {
      const job = todo.shift();
      if (!job) return;
      const [pane, k] = job;
      const cand = pane.cand;
      if (!cand.built[k]) {
        const table = cand.built[k] = buildCandidateTable(pane, pane.ep.decisions[k], k);
        table.el.setAttribute('class', 'candidates-parked');
        cand.wrap.appendChild(table.box);
        void table.box.offsetHeight; // lay it out now, in this task (nothing is painted meanwhile) ...
        table.box.classList.add('parked'); // ... and keep that layout while parked
      }
      later(next);
    });
    later(next);
  }

  /** Order the shown table's rows by the pane's sort column (given order when none). */
  function sortCandidates(pane) {
    const cand = pane.cand;
    const table = cand.table;
    const d = table.d;
    const j = cand.sort ? d.columns.indexOf(cand.sort.col) : -1;
    const dir = j >= 0 ? cand.sort.dir : 0;
    const key = j + ':' + dir;
    if (table.order === key) return;
    table.order = key;
    const order = d.rows.map((_, i) => i);
    if (j >= 0) {
      const val = (v) => (v === null || v === undefined ? null : isNaN(num(v)) ? String(v) : num(v));
      order.sort((a, b) => {
        const x = val(d.rows[a][j]), y = val(d.rows[b][j]);
        if (x === null || y === null) return x === y ? a - b : x === null ? 1 : -1; // missing last
        const c = typeof x === 'number' && typeof y === 'number' ? (x === y ? 0 : x < y ? -1 : 1)
          : String(x).localeCompare(String(y));
        return c * dir || a - b;
      });
    }
    table.ths.forEach((th, i) => {
      th.setAttribute('aria-sort', i === j ? (dir > 0 ? 'ascending' : 'descending') : 'none');
    });
    for (const i of order) table.tbody.appendChild(table.trs[i]);
  }

  // ----------------------------------------------------------------- factors that moved a belief
  /** The factors whose removal would move the selected object's location belief most (total
   * variation), as the log records them at the latest belief step (docs/design.md §4.8). */
  function buildMoved(pane, parent) {
    h('h3', null, parent, 'What moved the belief');
    const inf = pane.ep.inference;
    const how = inf ? 'location queries: ' + inf.locations + ' · task states: ' + inf.states +
      (inf.components ? ' · ' + inf.components.map((c) => c.variables.join(', ') + ' by ' + c.method).join('; ')
        : '') : 'this log does not record the exact method of each query';
    h('p', {class: 'note inference'}, parent, how);
    const head = h('div', {class: 'moved-head'}, parent);
    const tbody = h('tbody', null, h('table', {class: 'moved'}, h('div', {class: 'table-wrap moved-wrap'}, parent)));
    pane.moved = {head, tbody, shown: null};
  }

  function drawMoved(pane, k) {
    const ep = pane.ep;
    const m = (ep.moved || [])[ep.steps[k].moved];
    const key = (m ? m.seq : '-') + '|' + object;
    if (pane.moved.shown === key) return;
    pane.moved.shown = key;
    const {head, tbody} = pane.moved;
    tbody.textContent = '';
    const att = ep.inference && ep.inference.attribution;
    if (!att || !m) {
      head.textContent = 'this log does not record which factors moved a belief';
      return;
    }
    if (!att.factors.length) {
      head.textContent = att.notes && att.notes.length ? att.notes.join('; ')
        : 'nothing to attribute: the model has no factor beyond each object\'s prior and the looks';
      return;
    }
    const where = ' (belief at event ' + m.seq + ')';
    if (m.note) { head.textContent = m.note + where; return; }
    const by = m.by[object] || {};
    const names = Object.keys(by);
    head.textContent = names.length
      ? 'without each factor, the ' + object + '\'s belief would differ by (total variation)' + where
      : 'no factor moved the ' + object + '\'s belief by more than ' + att.threshold_tv +
        ' (total variation) beyond its prior and the looks' + where;
    for (const name of names) {
      const tr = h('tr', {'data-factor': name}, tbody);
      h('th', {scope: 'row'}, tr, name);
      h('td', {class: 'tv'}, tr, fmtP(by[name]));
      const fill = h('span', {class: 'fill'}, h('span', {class: 'bar'}, h('td', {class: 'bar-cell'}, tr)));
      fill.style.width = clamp(by[name], 0, 1) * 100 + '%';
    }
  }

  // ---------------------------------------------------------------------------- hidden states
  function buildStates(pane, parent) {
    h('h3', null, parent, 'Hidden states');
    const names = stateNames(pane.ep);
    pane.states = {names, cells: {}};
    if (!names.length) { h('p', {class: 'note'}, parent, 'no hidden states in this episode'); return; }
    const wrap = h('div', {class: 'table-wrap states-wrap'}, parent);
    const tbody = h('tbody', null, h('table', {class: 'states'}, wrap));
    for (const name of names) {
      const tr = h('tr', {'data-state': name}, tbody);
      const th = h('th', {scope: 'row'}, tr, name);
      th.style.borderLeftColor = colourOf[name];
      const td = h('td', {class: 'p', 'data-state': name}, tr, '');
      const fill = h('span', {class: 'fill'}, h('span', {class: 'bar'}, h('td', {class: 'bar-cell'}, tr)));
      pane.states.cells[name] = {tr, td, fill};
    }
  }

  /** Every hidden state named in the episode's steps, in order of appearance. */
  function stateNames(ep) {
    const seen = new Set();
    for (const st of ep.steps) for (const k in st.states || {}) seen.add(k);
    return Array.from(seen);
  }

  function drawStates(pane, k) {
    const st = pane.ep.steps[k].states || {};
    const before = k > 0 ? pane.ep.steps[k - 1].states || {} : st;
    for (const name of pane.states.names) {
      const cell = pane.states.cells[name];
      const p = st[name];
      cell.td.textContent = fmtP(p);
      cell.fill.style.width = (typeof p === 'number' ? clamp(p, 0, 1) * 100 : 0) + '%';
      cell.tr.classList.toggle('changed', p !== before[name]);
    }
  }

  // ------------------------------------------------------------------------------- task graph
  const NW = 100, NH = 32, GX = 30, GY = 10, PAD = 8; // node size and gaps, SVG units = px
  const BAND = 1; // rows left empty between two bands of a folded task graph

  function buildTasks(pane, parent) {
    h('h3', null, parent, 'Task graph');
    const ids = pane.ep.tasks || [];
    pane.tasks = [];
    if (!ids.length) { h('p', {class: 'note'}, parent, 'this log records no task statuses'); return; }
    const edges = pane.ep.task_edges !== undefined ? pane.ep.task_edges : data.task_edges;
    const layout = edges ? layeredLayout(ids, edges) : null;
    if (!layout) {
      h('p', {class: 'note'}, parent, edges ? 'task graph edges not available (the edges form a cycle); '
        + 'actions in order' : 'task graph edges not available; actions in order');
    }
    const cols = 4;
    const wrap = h('div', {class: 'tasks-wrap'}, parent);
    let pos = layout ? layout.pos : ids.map((_, k) => [k % cols, Math.floor(k / cols)]);
    // A graph too long for its box at 80 % of natural size is folded into bands of layers, one
    // under the other (the last layer of a band leads to the first of the next), so that it fits
    // half of a 1,400 px window instead of scrolling out of sight.
    const layers = Math.max(1, ...pos.map((p) => p[0] + 1));
    const fit = Math.max(2, Math.floor(((wrap.clientWidth || 1e9) / 0.8 - 2 * PAD + GX) / (NW + GX)));
    const bands = layout && layers > fit ? Math.ceil(layers / fit) : 1;
    const perBand = Math.ceil(layers / bands);
    const tall = Math.max(1, ...pos.map((p) => p[1] + 1));
    if (bands > 1) {
      pos = pos.map(([c, r]) => [c % perBand, r + Math.floor(c / perBand) * (tall + BAND)]);
    }
    const ncol = Math.max(1, ...pos.map((p) => p[0] + 1));
    const nrow = Math.max(1, ...pos.map((p) => p[1] + 1));
    const W = PAD * 2 + ncol * NW + (ncol - 1) * GX;
    const H = PAD * 2 + nrow * NH + (nrow - 1) * GY;
    const svg = s('svg', {class: 'tasks', viewBox: '0 0 ' + W + ' ' + H, role: 'img', 'aria-label': 'task graph'},
                  wrap);
    // Shrink to the pane down to 80 % of natural size; beyond that the box scrolls sideways.
    svg.style.maxWidth = W + 'px';
    svg.style.minWidth = Math.round(W * 0.8) + 'px';
    pane.tasksBox = {wrap, svg, W, active: ''};
    const at = (k) => [PAD + pos[k][0] * (NW + GX), PAD + pos[k][1] * (NH + GY)];
    if (layout) {
      const marker = s('marker', {id: 'arrow-' + pane.i, viewBox: '0 0 10 10', refX: 10, refY: 5,
                                  markerWidth: 7, markerHeight: 7, orient: 'auto'}, s('defs', null, svg));
      s('path', {d: 'M0,0L10,5L0,10z', class: 'arrow-head'}, marker);
      const gEdges = s('g', {class: 'edges'}, svg);
      for (const [a, b] of layout.edges) {
        const [ax, ay] = at(a), [bx, by] = at(b);
        const x1 = ax + NW, y1 = ay + NH / 2, x2 = bx, y2 = by + NH / 2, mx = (x1 + x2) / 2;
        // Into a later band: right, down into the gap above the target's band, left, then in.
        const band = (k) => Math.floor(pos[k][1] / (tall + BAND));
        const gap = PAD + (band(b) * (tall + BAND) - BAND / 2) * (NH + GY) - GY / 2;
        const d = band(a) === band(b)
          ? 'M' + x1 + ',' + y1 + 'C' + mx + ',' + y1 + ' ' + mx + ',' + y2 + ' ' + x2 + ',' + y2
          : 'M' + x1 + ',' + y1 + 'H' + (x1 + GX / 2) + 'V' + gap + 'H' + (x2 - PAD / 2) + 'V' + y2 + 'H' + x2;
        s('path', {class: 'edge', 'data-from': ids[a], 'data-to': ids[b],
                   'marker-end': 'url(#arrow-' + pane.i + ')', d}, gEdges);
      }
    }
    ids.forEach((id, k) => {
      const [x, y] = at(k);
      const g = s('g', {class: 'task', 'data-task': id, 'data-status': 'pending',
                        transform: 'translate(' + x + ',' + y + ')'}, svg);
      s('rect', {width: NW, height: NH, rx: 6}, g);
      const words = String(id).split('_');
      const lines = words.length > 1 ? [words[0], words.slice(1).join(' ')] : [id];
      lines.forEach((line, j) => s('text', {x: NW / 2, y: NH / 2 + (j - (lines.length - 1) / 2) * 12 + 4,
                                            'text-anchor': 'middle'}, g, line));
      const title = s('title', null, g, id + ': pending');
      pane.tasks.push({g, title, id, status: 'pending', x: x + NW / 2});
    });
    const legend = h('div', {class: 'legend status-legend'}, parent);
    for (const st of ['pending', 'active', 'complete', 'skipped', 'failed']) {
      h('span', {class: 'status-key', 'data-status': st}, legend, st);
    }
  }

  /** Longest-path layers (left to right), ordered within each layer by the barycentre of their
   *  neighbours in the previous (then next) layer. Returns {pos: [[layer, row] per id], edges:
   *  [[from, to] as indices]} or null when the edges form a cycle. */
  function layeredLayout(ids, edgeNames) {
    const index = {};
    ids.forEach((id, k) => { index[id] = k; });
    const edges = edgeNames.filter(([a, b]) => a in index && b in index)
      .map(([a, b]) => [index[a], index[b]]);
    const preds = ids.map(() => []), succs = ids.map(() => []);
    for (const [a, b] of edges) { preds[b].push(a); succs[a].push(b); }
    // Kahn's topological order, then layer = 1 + the deepest predecessor's layer.
    const indeg = preds.map((p) => p.length);
    const queue = ids.map((_, k) => k).filter((k) => indeg[k] === 0);
    const order = [];
    while (queue.length) {
      const k = queue.shift();
      order.push(k);
      for (const m of succs[k]) if (--indeg[m] === 0) queue.push(m);
    }
    if (order.length !== ids.length) return null;
    const layer = ids.map(() => 0);
    for (const k of order) for (const m of succs[k]) layer[m] = Math.max(layer[m], layer[k] + 1);
    const layers = [];
    ids.forEach((_, k) => { (layers[layer[k]] = layers[layer[k]] || []).push(k); });
    const row = ids.map(() => 0);
    const place = () => layers.forEach((l) => l.forEach((k, r) => { row[k] = r; }));
    place();
    const bary = (k, nb) => (nb[k].length ? nb[k].reduce((t, m) => t + row[m], 0) / nb[k].length : row[k]);
    const reorder = (L, nb) => { layers[L].sort((a, b) => bary(a, nb) - bary(b, nb) || a - b); place(); };
    for (let sweep = 0; sweep < 2; sweep++) {
      for (let L = 1; L < layers.length; L++) reorder(L, preds);
      for (let L = layers.length - 2; L >= 0; L--) reorder(L, succs);
    }
    // Centre each layer vertically against the tallest one (half rows are fine).
    const tallest = Math.max(...layers.map((l) => l.length));
    const pos = ids.map((_, k) => [layer[k], row[k] + (tallest - layers[layer[k]].length) / 2]);
    return {pos, edges};
  }

  function drawTasks(pane, st) {
    const codes = pane.ep.task_codes || [];
    pane.tasks.forEach((node, k) => {
      const status = codes[(st.tasks || [])[k]] || 'pending';
      if (status === node.status) return;
      node.status = status;
      node.g.setAttribute('data-status', status);
      node.g.classList.toggle('active', status === 'active');
      node.title.textContent = node.id + ': ' + status;
    });
    // Keep the first active action in view when the graph is wider than its box.
    const box = pane.tasksBox;
    const active = pane.tasks.filter((n) => n.status === 'active');
    const key = active.map((n) => n.id).join(' ');
    if (!box || key === box.active) return;
    box.active = key;
    if (!active.length) return;
    afterFrame(() => { // after the step is drawn: reading sizes forces a layout
      if (box.wrap.scrollWidth <= box.wrap.clientWidth) return;
      const x = active[0].x * box.svg.clientWidth / box.W;
      box.wrap.scrollLeft = Math.max(0, x - box.wrap.clientWidth / 2);
    });
  }

  // ----------------------------------------------------------------------------------- charts
  function buildCharts(pane, parent) {
    const ep = pane.ep;
    pane.charts = [];
    const ent = ep.objects.map((o) => ({name: o, values: ep.steps.map((st) => (st.entropy || {})[o])}));
    pane.charts.push(lineChart(pane, parent, 'entropy', 'Entropy of each object\'s location belief (nats)',
                               ent, entropyMax));
    const names = pane.states.names;
    if (names.length) {
      const sts = names.map((n) => ({name: n, values: ep.steps.map((st) => (st.states || {})[n])}));
      pane.charts.push(lineChart(pane, parent, 'state-chart', 'Hidden-state probabilities', sts, 1));
    }
  }

  /** A line chart of series over this episode's steps, with a cursor; a click jumps to a step. */
  function lineChart(pane, parent, cls, title, series, ymax) {
    const n = pane.ep.steps.length;
    const W = 600, H = 170, L = 36, R = 10, T = 10, B = 24;
    const x = (i) => +(L + (n > 1 ? i / (n - 1) : 0.5) * (W - L - R)).toFixed(1);
    const y = (v) => +(T + (1 - v / ymax) * (H - T - B)).toFixed(1);
    const box = h('figure', {class: 'chart ' + cls + '-box'}, parent);
    h('figcaption', null, box, title);
    const svg = s('svg', {class: cls, viewBox: '0 0 ' + W + ' ' + H, role: 'img', 'aria-label': title}, box);
    const axes = s('g', {class: 'axes'}, svg);
    for (const v of [0, ymax / 2, ymax]) {
      s('line', {class: v ? 'grid' : 'axis', x1: L, x2: W - R, y1: y(v), y2: y(v)}, axes);
      s('text', {x: L - 4, y: y(v) + 4, 'text-anchor': 'end'}, axes, +v.toFixed(2));
    }
    const every = Math.max(1, Math.ceil(n / 10 / 5) * 5);
    for (let i = 0; i < n; i += every) s('text', {x: x(i), y: H - 8, 'text-anchor': 'middle'}, axes, i + 1);
    for (const d of pane.ep.decisions) {
      s('line', {class: 'decision-mark', x1: x(d.step), x2: x(d.step), y1: T, y2: H - B}, axes);
    }
    for (const ser of series) {
      // Missing values break the line (a path of separate runs).
      let d = '', pen = false;
      ser.values.forEach((v, i) => {
        const ok = isFinite(num(v));
        if (ok) d += (pen ? 'L' : 'M') + x(i) + ',' + y(clamp(num(v), 0, ymax));
        pen = ok;
      });
      const line = s('path', {class: 'series', 'data-series': ser.name, d, stroke: colourOf[ser.name]}, svg);
      s('title', null, line, ser.name);
    }
    const cursor = s('line', {class: 'cursor', x1: L, x2: L, y1: T - 4, y2: H - B}, svg);
    svg.addEventListener('click', (e) => safe(() => {
      const pt = svg.createSVGPoint();
      pt.x = e.clientX;
      pt.y = e.clientY;
      const local = pt.matrixTransform(svg.getScreenCTM().inverse());
      goToStep(pane, clamp(Math.round((local.x - L) / (W - L - R) * (n - 1)), 0, n - 1));
    }));
    const legend = h('div', {class: 'legend series-legend'}, box);
    for (const ser of series) {
      const key = h('span', {class: 'series-key', 'data-series': ser.name}, legend, ser.name);
      key.style.borderColor = colourOf[ser.name];
    }
    return {svg, move: (k) => setAttrs(cursor, {x1: x(k), x2: x(k)})};
  }

  // ------------------------------------------------------------------------------- the steps
  /** Show slider position i (clamped) in every pane; synchronous. Returns the index shown. */
  function go(i) {
    i = clamp(Math.round(Number(i)) || 0, 0, pairs.length - 1);
    cur = i;
    $('step-slider').value = String(i);
    $('step-label').textContent = 'step ' + (i + 1) + ' / ' + pairs.length;
    $('prev').disabled = i === 0;
    $('next').disabled = i === pairs.length - 1;
    if (panes.length > 1) {
      $('step-detail').textContent = panes.map((p) => LETTERS[p.i] + ': step ' + (stepOf(pairs[i], p.i) + 1) +
                                                       ' of ' + p.ep.steps.length).join(' · ');
    }
    if (!pinned) follow(i);
    for (const pane of panes) drawPane(pane, stepOf(pairs[i], pane.i));
    if (data.divergence) $('divergence').classList.toggle('here', data.divergence.pair === i);
    syncVideo();
    return i;
  }

  /** Shade the plans by the object of the decision in force (the first pane's, else the
   * second's) until the user picks an object. */
  function follow(i) {
    for (const pane of panes) {
      const steps = pane.ep.steps;
      for (let k = stepOf(pairs[i], pane.i); k >= 0; k--) {
        const d = steps[k].decision;
        if (d === null || d === undefined) continue;
        const name = pane.ep.decisions[d].object;
        if (name !== object && objects.indexOf(name) >= 0) { object = name; $('object').value = name; highlightSeries(); }
        return;
      }
    }
  }

  function highlightSeries() {
    for (const pane of panes) {
      pane.el.querySelectorAll('svg.entropy .series')
        .forEach((p) => p.classList.toggle('selected', p.dataset.series === object));
    }
  }

  function setObject(name) {
    if (objects.indexOf(name) < 0) throw new Error('no object ' + name + ' in this page');
    object = name;
    $('object').value = name;
    highlightSeries();
    if (cur >= 0) go(cur);
  }

  function init() {
    data = JSON.parse($('data').textContent);
    if (!data || !Array.isArray(data.episodes) || !data.episodes.length) {
      throw new Error('the page data holds no episode');
    }
    if (!data.house || !data.house.floor) throw new Error('the page data holds no house');
    data.episodes.forEach((ep, i) => {
      if (!ep.steps || !ep.steps.length) throw new Error('episode ' + (ep.label || i) + ' has no steps');
    });
    pairs = Array.isArray(data.pairs) && data.pairs.length ? data.pairs
      : data.episodes[0].steps.map((_, k) => [k]);
    for (const ep of data.episodes) for (const o of ep.objects || []) if (objects.indexOf(o) < 0) objects.push(o);
    objects.forEach((o, k) => { colourOf[o] = PALETTE[k % PALETTE.length]; });
    const states = [];
    for (const ep of data.episodes) for (const n of stateNames(ep)) if (states.indexOf(n) < 0) states.push(n);
    states.forEach((n, k) => { if (!(n in colourOf)) colourOf[n] = PALETTE[k % PALETTE.length]; });
    let top = 0;
    for (const ep of data.episodes) {
      for (const st of ep.steps) for (const o in st.entropy || {}) top = Math.max(top, num(st.entropy[o]) || 0);
    }
    entropyMax = Math.max(0.5, Math.ceil(top * 2) / 2);
    const first = data.episodes.map((ep) => (ep.decisions || [])[0]).find((d) => d && objects.indexOf(d.object) >= 0);
    object = first ? first.object : objects[0];
    // Slider positions where some pane arrives at a decision step (for PageUp / PageDown).
    decisionPairs = pairs.map((pr, k) => k).filter((k) => data.episodes.some((ep, i) => {
      const st = stepOf(pairs[k], i);
      const fresh = k === 0 || stepOf(pairs[k - 1], i) !== st;
      return fresh && ep.steps[st].decision !== null && ep.steps[st].decision !== undefined;
    }));

    buildHeader();
    buildNotices();
    buildControls();
    buildDivergence();
    $('panes').classList.toggle('two', data.episodes.length > 1);
    panes = data.episodes.map(buildPane);
    buildVideo();
    // For tests and the console; errors are shown on the page, then rethrown to the caller.
    const shown = (fn) => (...args) => { try { return fn(...args); } catch (err) { showError(err); throw err; } };
    window.explorer = {data, go: shown(go), index: () => cur,
                       object: shown((name) => (name === undefined ? object : (pinned = true, setObject(name))))};
    setObject(object);
    go(0);
    const loading = $('loading');
    if (loading) loading.remove();
    document.body.dataset.ready = '1';
    warmTables();
  }

  window.addEventListener('error', (e) => {
    if ($('error').hidden) { $('error').hidden = false; $('error').textContent = 'The explorer failed: ' + e.message; }
  });
  try { init(); } catch (err) { showError(err); }
})();
