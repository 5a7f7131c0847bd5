// The 3-D race replay page (`f16race replay --html`): reads the race JSON that lib/eval/replay_page.cpp
// wrote into #race-data and draws it with three.js (the global THREE of build/three.min.js, inlined
// before this script). No network: everything it needs is in the page.
//
// Coordinates. The simulator's positions are north, east, altitude [ft] and its attitudes the
// aerospace Euler angles phi (roll), theta (pitch), psi (yaw) of the body axes (x nose, y right
// wing, z down) in the local NED frame. three.js is right-handed with y up, so a world point maps as
//   three = (x, y, z) = (east, altitude, -north)
// (ENU is right-handed, and (e, u, -n) is ENU turned a quarter about east: still right-handed), i.e.
// an NED vector (n, e, d) becomes (e, -d, -n): the matrix T below. The aircraft model is built in
// body axes, so its orientation is T * R_nb(phi, theta, psi), R_nb = Rz(psi) Ry(theta) Rx(phi).
(function () {
  'use strict';
  const D = JSON.parse(document.getElementById('race-data').textContent);
  const N = D.frames, DT = D.dt_s, NA = D.aircraft.length;
  const LAST_T = (N - 1) * DT;
  const TRAIL_S = 8;           // seconds of trail behind each aircraft
  const GOAL_FLASH_S = 1.5;    // a changed HL goal is highlighted this long
  const BLOCK_HOLD_S = 1.0;    // a block stays drawn this long after its outcome
  const BG = 0x10141c;
  const $ = (id) => document.getElementById(id);
  const statusEl = $('f16race-status');

  let t = 0, playing = false, speed = 1, lastNow = null, webgl = true;
  let cam = { mode: 'orbit', who: 0 };
  const orbit = { az: -0.6, el: 0.55, dist: 1, target: null };  // set from the track below
  const follow = { az: -2.4, el: 0.3, dist: 900 };

  // --- data helpers ----------------------------------------------------------------------------
  const teamHue = [215, 4];
  function aircraftColor(a) {
    const ac = D.aircraft[a], k = a % D.team_size;
    const c = new THREE.Color();
    c.setHSL(teamHue[ac.team] / 360, 0.85, 0.48 + 0.3 * (k / Math.max(1, D.team_size - 1)));
    return c;
  }
  const posAt = (ac, k) => new THREE.Vector3(ac.e[k], ac.u[k], -ac.n[k]);
  function attitudeAt(ac, k) {
    const f = 0.01;  // the JSON holds angles in centiradians
    const cf = Math.cos(ac.phi[k] * f), sf = Math.sin(ac.phi[k] * f);
    const ct = Math.cos(ac.theta[k] * f), st = Math.sin(ac.theta[k] * f);
    const cp = Math.cos(ac.psi[k] * f), sp = Math.sin(ac.psi[k] * f);
    // Rows: T * R_nb, i.e. east row of R_nb, minus its down row, minus its north row.
    const m = new THREE.Matrix4().set(
      ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp, 0,
      st, -sf * ct, -cf * ct, 0,
      -ct * cp, -(sf * st * cp - cf * sp), -(cf * st * cp + sf * sp), 0,
      0, 0, 0, 1);
    return new THREE.Quaternion().setFromRotationMatrix(m);
  }
  const alive = (ac, k) => k < ac.n.length;
  const frameOf = (time) => Math.min(N - 1, Math.max(0, Math.floor(time / DT + 1e-6)));
  const fmtT = (s) => s.toFixed(1) + ' s';

  // Ranks as the race computes them (race/ranking.hpp): live aircraft ahead of terminated ones,
  // each group by progress; ties share a rank.
  function ranks(k) {
    const key = D.aircraft.map((ac) => {
      const on = alive(ac, k), j = Math.min(k, ac.s.length - 1);
      return { on, s: ac.s[j] };
    });
    return key.map((me) => key.filter((o) => (o.on && !me.on) || (o.on === me.on && o.s > me.s)).length);
  }
  // The HL goal in force at `time` (index into ac.goals, -1 before the first decision).
  function goalIndex(ac, time) {
    let g = -1;
    for (let i = 0; i < ac.goals.length && ac.goals[i][0] <= time + 1e-9; ++i) g = i;
    return g;
  }
  // Decisions whose bins differ from the aircraft's previous goal: the moments its goal changes.
  const goalChanges = D.aircraft.map((ac) => ac.goals.map((g, i) => i === 0 || g.slice(4).join() !== ac.goals[i - 1].slice(4).join()));

  // --- scene ---------------------------------------------------------------------------------------
  let renderer = null;
  try {
    renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true, logarithmicDepthBuffer: true });
  } catch (e) {
    webgl = false;
  }
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(BG);
  const camera = new THREE.PerspectiveCamera(50, 1, 5, 2e6);
  scene.add(new THREE.HemisphereLight(0xdde8ff, 0x404040, 0.9));
  const sun = new THREE.DirectionalLight(0xffffff, 0.6);
  sun.position.set(0.3, 1, 0.2);
  scene.add(sun);

  function buildTrack() {
    const tr = D.track, n = tr.n.length;
    const c = [], r = tr.r;
    for (let i = 0; i < n; ++i) c.push(new THREE.Vector3(tr.e[i], tr.u[i], -tr.n[i]));
    const box = new THREE.Box3().setFromPoints(c);
    orbit.target = box.getCenter(new THREE.Vector3());
    orbit.dist = 1.1 * box.getSize(new THREE.Vector3()).length();
    // Local frames of the tube: tangent, right (horizontal), up, as race/track.hpp defines them.
    const frames = c.map((p, i) => {
      const tan = c[Math.min(n - 1, i + 1)].clone().sub(c[Math.max(0, i - 1)]).normalize();
      const right = tan.clone().cross(new THREE.Vector3(0, 1, 0)).normalize();
      return { tan, right, up: right.clone().cross(tan) };
    });
    const SEG = 28, pos = [], idx = [];
    for (let i = 0; i < n; ++i)
      for (let j = 0; j < SEG; ++j) {
        const a = (2 * Math.PI * j) / SEG;
        const v = c[i].clone().addScaledVector(frames[i].right, r[i] * Math.cos(a)).addScaledVector(frames[i].up, r[i] * Math.sin(a));
        pos.push(v.x, v.y, v.z);
      }
    for (let i = 0; i + 1 < n; ++i)
      for (let j = 0; j < SEG; ++j) {
        const a = i * SEG + j, b = i * SEG + ((j + 1) % SEG);
        idx.push(a, b, a + SEG, b, b + SEG, a + SEG);
      }
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
    g.setIndex(idx);
    g.computeVertexNormals();
    scene.add(new THREE.Mesh(g, new THREE.MeshLambertMaterial({ color: 0x3f8fd8, transparent: true, opacity: 0.13,
                                                                 side: THREE.DoubleSide, depthWrite: false })));
    // Rings every ~2 000 ft give the tube's shape at a glance, the center line its course.
    const ringMat = new THREE.LineBasicMaterial({ color: 0x5fa8e8, transparent: true, opacity: 0.35 });
    const every = Math.max(1, Math.round(2000 / tr.spacing_ft));
    for (let i = 0; i < n; i += every) {
      const ring = [];
      for (let j = 0; j < SEG; ++j) ring.push(new THREE.Vector3(pos[3 * (i * SEG + j)], pos[3 * (i * SEG + j) + 1], pos[3 * (i * SEG + j) + 2]));
      scene.add(new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints(ring), ringMat));
    }
    scene.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(c),
                             new THREE.LineBasicMaterial({ color: 0xf2d04b, transparent: true, opacity: 0.7 })));
    // The racing line the goals were placed around (race.goal_line_frac), when there is one.
    const rl = D.racing_line;
    if (rl) {
      const q = rl.n.map((_, i) => new THREE.Vector3(rl.e[i], rl.u[i], -rl.n[i]));
      const dashed = new THREE.Line(new THREE.BufferGeometry().setFromPoints(q),
                                    new THREE.LineDashedMaterial({ color: 0x7cf29a, dashSize: 300, gapSize: 200 }));
      dashed.computeLineDistances();
      scene.add(dashed);
    }
    // The finish gate: a ring across the tube where the race counts as finished.
    const fi = Math.min(n - 1, Math.round(tr.finish_s_ft / tr.spacing_ft));
    const gate = new THREE.Mesh(new THREE.TorusGeometry(r[fi], r[fi] * 0.04, 8, 64),
                                new THREE.MeshLambertMaterial({ color: 0xffffff, emissive: 0x553300 }));
    gate.position.copy(c[fi]);
    gate.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), frames[fi].tan);
    scene.add(gate);
    const label = makeLabel('FINISH', '#ffffff');
    label.position.copy(c[fi]).addScaledVector(frames[fi].up, r[fi] * 1.1);
    scene.add(label);
    const grid = new THREE.GridHelper(orbit.dist * 1.5, 30, 0x2a3444, 0x1d2533);
    grid.position.set(orbit.target.x, 0, orbit.target.z);  // y = 0: sea level
    scene.add(grid);
  }

  function makeLabel(text, color, height) {
    const cv = document.createElement('canvas'), px = 40;
    const ctx = cv.getContext('2d');
    ctx.font = `bold ${px}px sans-serif`;
    cv.width = Math.ceil(ctx.measureText(text).width) + 12;
    cv.height = px + 12;
    ctx.font = `bold ${px}px sans-serif`;
    ctx.fillStyle = 'rgba(10,12,18,0.55)';
    ctx.fillRect(0, 0, cv.width, cv.height);
    ctx.fillStyle = color;
    ctx.fillText(text, 6, px);
    const tex = new THREE.CanvasTexture(cv);
    const s = new THREE.Sprite(new THREE.SpriteMaterial({ map: tex, sizeAttenuation: false, depthTest: false, transparent: true }));
    const h = height || 0.024;  // of the view's height (no size attenuation: the same at every distance)
    s.scale.set((h * cv.width) / cv.height, h, 1);
    s.center.set(0.5, -0.4);    // above the point it marks
    s.renderOrder = 10;
    return s;
  }

  // A small delta-wing aircraft in body axes (x nose, y right wing, z down), 1 unit long.
  function aircraftGeometry() {
    const v = [
      0.55, 0, 0, -0.5, 0, -0.06, -0.5, 0.06, 0,   0.55, 0, 0, -0.5, -0.06, 0, -0.5, 0, -0.06,   // fuselage
      0.55, 0, 0, -0.5, 0.06, 0, -0.5, 0, 0.05,    0.55, 0, 0, -0.5, 0, 0.05, -0.5, -0.06, 0,
      0.25, 0, 0, -0.3, 0.5, 0, -0.3, -0.5, 0,                                                   // wing
      -0.3, 0, 0, -0.5, 0.22, 0, -0.5, -0.22, 0,                                                 // tailplane
      -0.2, 0, 0, -0.5, 0, -0.32, -0.5, 0, 0,                                                    // fin (up is -z)
    ];
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(v, 3));
    g.computeVertexNormals();
    return g;
  }

  const planeGeom = aircraftGeometry();
  const goalGeom = new THREE.OctahedronGeometry(0.35);
  const trailN = Math.max(2, Math.round(TRAIL_S / DT) + 2);
  const bgColor = new THREE.Color(BG);
  const actors = D.aircraft.map((ac, a) => {
    const color = aircraftColor(a);
    const model = new THREE.Mesh(planeGeom, new THREE.MeshLambertMaterial({ color, side: THREE.DoubleSide, emissive: color.clone().multiplyScalar(0.25) }));
    const label = makeLabel(ac.label, '#' + color.getHexString());
    const trailGeom = new THREE.BufferGeometry();
    trailGeom.setAttribute('position', new THREE.BufferAttribute(new Float32Array(trailN * 3), 3));
    const cols = new Float32Array(trailN * 3);
    for (let i = 0; i < trailN; ++i) {  // head (index 0) in the aircraft's colour, fading into the background
      const c = color.clone().lerp(bgColor, i / (trailN - 1));
      cols.set([c.r, c.g, c.b], 3 * i);
    }
    trailGeom.setAttribute('color', new THREE.BufferAttribute(cols, 3));
    const trail = new THREE.Line(trailGeom, new THREE.LineBasicMaterial({ vertexColors: true }));
    trail.frustumCulled = false;
    const goal = new THREE.Mesh(goalGeom, new THREE.MeshBasicMaterial({ color, wireframe: true }));
    const goalLine = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]),
                                    new THREE.LineBasicMaterial({ color, transparent: true, opacity: 0.35 }));
    goalLine.frustumCulled = false;
    const k = ac.n.length - 1;
    const outMark = makeLabel('\u2715 ' + ac.label + ': ' + ac.cause + ' at ' + fmtT(ac.out_s), '#ff6b5e');
    outMark.center.set(0.5, 0.5);
    if (k >= 0) outMark.position.copy(posAt(ac, k));
    [model, label, trail, goal, goalLine, outMark].forEach((o) => scene.add(o));
    return { color, model, label, trail, goal, goalLine, outMark, pos: new THREE.Vector3(), quat: new THREE.Quaternion() };
  });

  const blockLines = D.blocks.map(() => {
    const l = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]),
                             new THREE.LineBasicMaterial({ color: 0xffa31a }));
    l.frustumCulled = false;
    scene.add(l);
    const tag = makeLabel('BLOCK', '#ffa31a', 0.024);
    scene.add(tag);
    return { l, tag };
  });
  buildTrack();

  // --- state at time t -----------------------------------------------------------------------------
  function placeAircraft(time, camPos) {
    const f = time / DT, k = Math.floor(f + 1e-6), w = Math.max(0, f - k);
    D.aircraft.forEach((ac, a) => {
      const A = actors[a], on = alive(ac, k);
      if (on) {
        const k1 = Math.min(k + 1, ac.n.length - 1);
        A.pos.copy(posAt(ac, k)).lerp(posAt(ac, k1), w);
        A.quat.copy(attitudeAt(ac, k)).slerp(attitudeAt(ac, k1), w);
      } else if (ac.n.length > 0) {
        A.pos.copy(posAt(ac, ac.n.length - 1));
      }
      A.model.visible = A.label.visible = A.trail.visible = on;
      A.outMark.visible = !on && ac.out_s >= 0 && time + 1e-9 >= ac.out_s - DT;
      A.model.position.copy(A.pos);
      A.model.quaternion.copy(A.quat);
      A.label.position.copy(A.pos);
      // At least ~2 % of the view's height: larger than life (a 50 ft F-16) when far away, so a
      // whole-track view still shows every aircraft and its attitude.
      const size = Math.min(3000, Math.max(50, 0.03 * camPos.distanceTo(A.pos)));
      A.model.scale.setScalar(size);
      const tp = A.trail.geometry.attributes.position;
      let m = 0;
      for (let j = Math.min(k, ac.n.length - 1); m < trailN && j >= 0 && j > k - trailN; --j, ++m) {
        const p = m === 0 ? A.pos : posAt(ac, j);
        tp.setXYZ(m, p.x, p.y, p.z);
      }
      tp.needsUpdate = true;
      A.trail.geometry.setDrawRange(0, m);
      const g = goalIndex(ac, time);
      A.goal.visible = A.goalLine.visible = on && g >= 0;
      if (g >= 0) {
        const G = ac.goals[g], fresh = goalChanges[a][g] && time - G[0] < GOAL_FLASH_S;
        A.goal.position.set(G[2], G[3], -G[1]);
        A.goal.scale.setScalar(size * (fresh ? 2.2 : 1));
        A.goal.rotation.y = time;
        const gp = A.goalLine.geometry.attributes.position;
        gp.setXYZ(0, A.pos.x, A.pos.y, A.pos.z);
        gp.setXYZ(1, G[2], G[3], -G[1]);
        gp.needsUpdate = true;
      }
    });
    D.blocks.forEach((b, i) => {
      const on = time >= b[2] && time <= b[3] + BLOCK_HOLD_S;
      const L = blockLines[i];
      L.l.visible = L.tag.visible = on;
      if (!on) return;
      const p = L.l.geometry.attributes.position, A = actors[b[0]].pos, B = actors[b[1]].pos;
      p.setXYZ(0, A.x, A.y, A.z);
      p.setXYZ(1, B.x, B.y, B.z);
      p.needsUpdate = true;
      L.tag.position.copy(A).lerp(B, 0.5);
    });
  }

  function leader(k) {
    const r = ranks(k);
    let best = 0;
    for (let a = 0; a < NA; ++a) if (r[a] < r[best] || (r[a] === r[best] && alive(D.aircraft[a], k) && !alive(D.aircraft[best], k))) best = a;
    return best;
  }

  function placeCamera(k) {
    const sph = (o, target) => {
      camera.position.set(target.x + o.dist * Math.cos(o.el) * Math.sin(o.az), target.y + o.dist * Math.sin(o.el),
                          target.z + o.dist * Math.cos(o.el) * Math.cos(o.az));
      camera.lookAt(target);
    };
    if (cam.mode === 'orbit') return sph(orbit, orbit.target);
    if (cam.mode === 'follow') return sph(follow, actors[cam.who].pos);
    // Chase: behind and above the leader, looking along its nose.
    const A = actors[leader(k)];
    const nose = new THREE.Vector3(1, 0, 0).applyQuaternion(A.quat);
    camera.position.copy(A.pos).addScaledVector(nose, -900).add(new THREE.Vector3(0, 260, 0));
    camera.lookAt(A.pos.clone().addScaledVector(nose, 600));
  }

  // --- panels ------------------------------------------------------------------------------------------
  const rowsEl = $('board-rows');
  const boardRows = D.aircraft.map((ac, a) => {
    const tr = document.createElement('tr');
    tr.innerHTML = '<td></td><td class="name"></td>' + '<td></td>'.repeat(6);
    tr.children[1].textContent = ac.label;
    tr.children[1].style.color = '#' + actors[a].color.getHexString();
    rowsEl.appendChild(tr);
    return tr;
  });
  function updateBoard(k, time) {
    const r = ranks(k);
    const order = [...Array(NA).keys()].sort((x, y) => r[x] - r[y] || x - y);
    order.forEach((a) => rowsEl.appendChild(boardRows[a]));
    D.aircraft.forEach((ac, a) => {
      const c = boardRows[a].children, on = alive(ac, k), j = Math.min(k, ac.n.length - 1);
      const g = goalIndex(ac, time);
      c[0].textContent = r[a] + 1;
      c[2].textContent = on ? Math.round(ac.vt[j] * 0.592484) : '';
      c[3].textContent = on ? (ac.mach[j] / 1000).toFixed(3) : '';
      c[4].textContent = on ? ac.thr[j] : '';
      c[5].textContent = on ? ac.u[j] : '';
      c[6].textContent = g >= 0 ? ac.goals[g].slice(4).join(',') : '\u2013';
      c[6].className = g >= 0 && goalChanges[a][g] && time - ac.goals[g][0] < GOAL_FLASH_S ? 'flash' : '';
      let st = on ? (ac.s[j] >= D.track.finish_s_ft ? 'finished' : 'racing') : ac.cause;
      D.blocks.forEach((b) => {
        if (on && time >= b[2] && time <= b[3] + BLOCK_HOLD_S) st = b[0] === a ? 'blocking' : b[1] === a ? 'blocked' : st;
      });
      c[7].textContent = st;
      boardRows[a].className = on ? '' : 'out';
    });
  }

  const events = [];  // [time, text, tick colour]
  D.aircraft.forEach((ac) => { if (ac.out_s >= 0) events.push([ac.out_s, `${ac.label} out: ${ac.cause}`, '#ff6b5e']); });
  D.blocks.forEach((b) => events.push([b[2], `${D.aircraft[b[0]].label} blocks ${D.aircraft[b[1]].label}: ` +
                                              (b[4] ? 'taken out' : 'passed by a teammate') + ` at ${fmtT(b[3])}`, '#ffa31a']));
  const decisions = new Map();  // HL decision time -> the aircraft whose goal changed then
  D.aircraft.forEach((ac, a) => ac.goals.forEach((g, i) => {
    if (!goalChanges[a][i]) return;
    const key = g[0].toFixed(2);
    decisions.set(key, (decisions.get(key) || []).concat(`${ac.label} \u2192 ${g.slice(4).join(',')}`));
  }));
  decisions.forEach((who, key) => events.push([+key, 'HL goals: ' + who.join('; '), '#8d97a8']));
  events.sort((x, y) => x[0] - y[0]);
  const eventEls = events.map((e) => {
    const div = document.createElement('div');
    div.textContent = `${fmtT(e[0])}  ${e[1]}`;
    div.title = div.textContent;
    div.style.borderLeft = `3px solid ${e[2]}`;
    div.style.paddingLeft = '4px';
    div.onclick = () => { setTime(e[0]); pause(); };
    $('events').appendChild(div);
    const tick = document.createElement('span');
    tick.style.left = `${(100 * e[0]) / Math.max(LAST_T, 1e-9)}%`;
    tick.style.background = e[2];
    $('ticks').appendChild(tick);
    return div;
  });

  // --- time, controls, fragment ------------------------------------------------------------------
  const slider = $('slider');
  slider.max = N - 1;
  function setTime(time) {
    t = Math.min(LAST_T, Math.max(0, time));
    draw();
  }
  function setFrame(k) { setTime(Math.min(N - 1, Math.max(0, Math.round(k))) * DT); }
  function play() {
    if (t >= LAST_T) t = 0;
    playing = true;
    lastNow = null;
    $('play').innerHTML = '&#10074;&#10074;';
  }
  function pause() {
    playing = false;
    $('play').innerHTML = '&#9654;';
    writeFragment();
  }
  function writeFragment() {
    const c = cam.mode === 'orbit' ? '' : cam.mode === 'chase' ? '&cam=chase' : `&cam=follow${cam.who}`;
    try { history.replaceState(null, '', `#t=${t.toFixed(2)}${c}`); } catch (e) { /* some file:// settings refuse it */ }
  }
  // `#t=20` opens paused at 20 s; `&cam=orbit|chase|followK` picks the camera; `&ui=0` hides the
  // panels (figures, and tests that measure the 3-D view alone).
  function readFragment() {
    const p = new URLSearchParams(location.hash.replace(/^#/, ''));
    ['title', 'events', 'board', 'controls'].forEach((id) => { $(id).style.display = p.get('ui') === '0' ? 'none' : ''; });
    const c = p.get('cam') || '';
    if (c === 'chase' || c === 'orbit') cam = { mode: c, who: 0 };
    const m = /^follow(\d+)$/.exec(c);
    if (m && +m[1] < NA) cam = { mode: 'follow', who: +m[1] };
    $('camera').value = cam.mode === 'follow' ? `follow${cam.who}` : cam.mode;
    const ts = parseFloat(p.get('t'));
    playing = false;
    if (Number.isFinite(ts)) {  // through the slider, as a user would set it
      slider.value = Math.round(Math.min(LAST_T, Math.max(0, ts)) / DT);
      slider.dispatchEvent(new Event('input'));
    } else {
      draw();
    }
  }
  slider.addEventListener('input', () => { setFrame(+slider.value); pause(); });
  $('play').onclick = () => (playing ? pause() : play());
  $('speed').onchange = (e) => { speed = +e.target.value; };
  const camSel = $('camera');
  [['orbit', 'camera: orbit the track'], ['chase', 'camera: chase the leader']]
    .concat(D.aircraft.map((ac, a) => [`follow${a}`, `camera: follow ${ac.label}`]))
    .forEach(([v, txt]) => camSel.add(new Option(txt, v)));
  camSel.onchange = () => {
    const v = camSel.value;
    cam = v.startsWith('follow') ? { mode: 'follow', who: +v.slice(6) } : { mode: v, who: 0 };
    if (!playing) writeFragment();
    draw();
  };
  window.addEventListener('hashchange', readFragment);
  window.addEventListener('keydown', (e) => {
    if (e.target.tagName === 'SELECT') return;
    if (e.code === 'Space') { e.preventDefault(); playing ? pause() : play(); }
    if (e.code === 'ArrowRight' || e.code === 'ArrowLeft') {
      setFrame(frameOf(t) + (e.code === 'ArrowRight' ? 1 : -1) * (e.shiftKey ? 10 : 1));
      pause();
    }
  });
  // Orbit and zoom with the mouse: drag turns the camera around its target, the wheel moves it in.
  let drag = null;
  const orbitState = () => (cam.mode === 'follow' ? follow : orbit);
  $('view').addEventListener('pointerdown', (e) => { drag = { x: e.clientX, y: e.clientY }; });
  window.addEventListener('pointerup', () => { drag = null; });
  window.addEventListener('pointermove', (e) => {
    if (!drag || cam.mode === 'chase') return;
    const o = orbitState();
    o.az -= (e.clientX - drag.x) * 0.005;
    o.el = Math.min(1.55, Math.max(-1.2, o.el + (e.clientY - drag.y) * 0.005));
    drag = { x: e.clientX, y: e.clientY };
    draw();
  });
  $('view').addEventListener('wheel', (e) => {
    e.preventDefault();
    const o = orbitState();
    o.dist = Math.min(5e5, Math.max(100, o.dist * Math.exp(e.deltaY * 0.001)));
    draw();
  }, { passive: false });

  // --- drawing -------------------------------------------------------------------------------------
  function resize() {
    const w = window.innerWidth, h = window.innerHeight;
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
    if (renderer) renderer.setSize(w, h);
  }
  let shownFrame = -1;
  function draw() {
    const k = frameOf(t);
    placeAircraft(t, camera.position);  // sizes from the previous camera: one frame behind, unseen
    placeCamera(k);
    placeAircraft(t, camera.position);
    if (renderer) renderer.render(scene, camera);
    $('clock').textContent = `${t.toFixed(2)} / ${LAST_T.toFixed(2)} s`;
    if (k !== shownFrame) {
      shownFrame = k;
      slider.value = k;
      updateBoard(k, t);
      events.forEach((e, i) => { eventEls[i].className = Math.abs(e[0] - t) < 1 ? 'now' : ''; });
    } else {
      updateBoard(k, t);
    }
    const lead = leader(k), la = D.aircraft[lead];
    statusEl.textContent = JSON.stringify({
      ready: !!window.f16raceReady, webgl, aircraft: NA, duration_s: D.duration_s, frames: N, dt_s: DT, frame: k,
      time_s: +t.toFixed(4), playing, camera: camSel.value, leader: lead,
      leader_s_ft: la.s[Math.min(k, la.s.length - 1)],
    });
  }
  function tick(now) {
    if (playing) {
      if (lastNow !== null) t += ((now - lastNow) / 1000) * speed;
      lastNow = now;
      if (t >= LAST_T) { t = LAST_T; pause(); }
      draw();
    }
    requestAnimationFrame(tick);
  }

  $('race-title').textContent = D.title;
  document.title = D.title;
  $('race-facts').textContent = `${NA} aircraft, ${D.end} after ${fmtT(D.duration_s)}, winner ${D.winner}; ` +
                                `track ${Math.round(D.track.length_ft)} ft; HL goal bins x,y,z (${D.goal_frame} frame)`;
  if (renderer) {
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    $('view').appendChild(renderer.domElement);
  } else {
    $('message').style.display = 'block';
    $('message').textContent = 'This browser could not start WebGL, so the 3-D view is off; the table and the timeline still work.';
  }
  window.addEventListener('resize', () => { resize(); draw(); });
  resize();
  readFragment();
  // For tests and scripts: the race's size, the frame shown, and the slider.
  window.f16race = {
    aircraft: NA, duration_s: D.duration_s, frames: N, dt_s: DT,
    frame: () => frameOf(t), time: () => t, setTime, setFrame, play, pause,
  };
  window.f16raceReady = true;
  draw();
  requestAnimationFrame(tick);
})();
