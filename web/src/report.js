/*
 * Whole-body motion report viewer.
 *
 * The page carries its data in <script type="application/json" id="wbm-data">,
 * written by the C++ report writer (every `<` in the JSON text escaped as
 * `\u003c`). It needs the globals THREE (three.js + THREE.OrbitControls) and
 * uPlot, inlined before this script. Data schema (N = time.length):
 *
 * {
 *   "title": "string",
 *   "subtitle": "string (optional)",
 *   "time": [t0, t1, ...],                  seconds, N samples, non-decreasing
 *   "robot": {
 *     "bodies": [{"name": "l_elbow", "parent": 3}, ...],
 *         the robot's links: its moving bodies and the links welded to them
 *         (locked legs, heads, sensors). parent: index into bodies, or -1 for
 *         the world. A link (cylinder) is drawn from the parent's origin to the
 *         body's origin (not for -1, nor when shorter than 1 mm); a small sphere
 *         marks every body origin.
 *     "frames": [{"name": "l_hand_ref"}, ...]
 *         named frames: a small sphere at the origin and a 0.1 m arrow along
 *         frame_z (grasp / view axis). Sizes here are for a robot 1.2 m tall;
 *         the viewer scales them by the robot's height (0.3 to 1.5 times).
 *   },
 *   "body_pos":  [[x0,y0,z0, x1,y1,z1, ...], ...]   N rows of 3*nbodies; world, metres, z up
 *                                                    (the C++ writer rounds them to 1e-6 m)
 *   "frame_pos": [[...], ...]                        N rows of 3*nframes
 *   "frame_z":   [[...], ...]                        N rows of 3*nframes, unit axis of each frame: its
 *                                                    z-axis, or the axis of the axis task on it
 *   "targets": [{"name": "r_hand position", "kind": "position" | "axis",
 *                "frame": 1,                          index into robot.frames
 *                "values": [[x,y,z] or null, ...]}]   N entries, null while inactive
 *       position: a translucent sphere (radius 2 cm) at the target point;
 *       axis: an arrow from the frame's current origin along the target direction.
 *   "footprints": [{"t": 1.2, "side": "L" | "R", "polygon": [[x,y], ...]}]   optional;
 *       outline drawn on the floor (z = 0) once t <= current time.
 *   "paths": [{"name": "heel", "points": [[x,y,z] or null, ...]}]             optional;
 *       N entries, drawn as a line up to the current time (null = gap).
 *   "plots": [{"title": "Joint angles", "unit": "rad",
 *              "series": [{"label": "l_sh0", "values": [N numbers or null]}]}],
 *       one chart per plot, all on the shared time axis (null = gap); with
 *       more than 4000 samples the charts show a min/max decimation.
 *   "summary": [["key", "value"], ...]                                       optional
 * }
 *
 * When the 3D view and every chart have been drawn once, window.wbmReady is
 * set to true (and window.wbmDrawingScale holds the scale of the drawn robot,
 * window.wbmPlotValueRanges() each chart's value axis as [min, max],
 * window.wbmBodiesOutOfView(k) how many body origins of sample k the camera's first
 * framing leaves out). Errors are reported with console.error and shown on the page.
 */
(function () {
  'use strict';

  const MAX_PLOT_POINTS = 4000;
  const PLOT_HEIGHT = 240;
  const FRAME_AXIS_LENGTH = 0.1;
  const TARGET_AXIS_LENGTH = 0.13;
  const TARGET_SPHERE_RADIUS = 0.02;
  const LINK_RADIUS = 0.014;
  const JOINT_RADIUS = 0.021;
  const FRAME_SPHERE_RADIUS = 0.016;
  const MIN_LINK_LENGTH = 0.001;
  // The sizes above are for a robot about 1.2 m tall (the paper's model, G1); a smaller or
  // larger robot gets them scaled by its height at sample 0 (NAO: about 0.45), within limits.
  const REFERENCE_HEIGHT = 1.2;
  const MIN_DRAWING_SCALE = 0.3;
  const MAX_DRAWING_SCALE = 1.5;
  const FLOOR_LIFT = 0.002;

  const COLORS = {
    background: 0xf3f5f8,
    grid: 0xb8c0cc,
    gridCenter: 0x8792a2,
    link: 0x8fa3ba,
    joint: 0x34495e,
    frame: 0xf28c28,
    targetPosition: 0x27ae60,
    targetAxis: 0xc2188b,
    footprintL: 0x1f77b4,
    footprintR: 0xd62728,
  };
  const PATH_COLORS = [0x7b4fc9, 0x16a2b8, 0x8c564b, 0xbcbd22, 0x444444];
  const SERIES_COLORS = [
    '#1f77b4', '#d62728', '#2ca02c', '#ff7f0e', '#9467bd',
    '#8c564b', '#e377c2', '#17becf', '#bcbd22', '#7f7f7f',
  ];
  const SERIES_DASHES = [undefined, [8, 4], [2, 3]];

  const Y_UP = new THREE.Vector3(0, 1, 0);

  function hex(color) {
    return '#' + color.toString(16).padStart(6, '0');
  }

  function showError(err) {
    const box = document.getElementById('error');
    const message = err && err.message ? err.message : String(err);
    box.hidden = false;
    box.textContent += (box.textContent ? '\n' : '') + 'Error: ' + message;
  }

  window.addEventListener('error', (event) => showError(event.error || event.message));
  window.addEventListener('unhandledrejection', (event) => showError(event.reason));

  // ---------------------------------------------------------------- data

  function readData() {
    const text = document.getElementById('wbm-data').textContent.trim();
    if (text === '__WBM_' + 'REPORT_DATA__') {
      throw new Error('this is the report template: no data has been inserted');
    }
    return JSON.parse(text);
  }

  function check(condition, message) {
    if (!condition) throw new Error('invalid report data: ' + message);
  }

  function isNumber(v) {
    return typeof v === 'number' && Number.isFinite(v);
  }

  function isVec3(v) {
    return Array.isArray(v) && v.length === 3 && v.every(isNumber);
  }

  function checkRows(rows, name, n, width) {
    check(Array.isArray(rows), `${name} must be an array of ${n} rows`);
    check(rows.length === n, `${name} has ${rows.length} rows, expected ${n} (one per time sample)`);
    for (let k = 0; k < n; k++) {
      const row = rows[k];
      check(Array.isArray(row) && row.length === width,
        `${name}[${k}] must have ${width} numbers, found ${Array.isArray(row) ? row.length : typeof row}`);
    }
  }

  function checkOptionalVectors(list, name, n) {
    check(Array.isArray(list) && list.length === n, `${name} must have ${n} entries (one per time sample)`);
    for (let k = 0; k < n; k++) {
      check(list[k] === null || isVec3(list[k]), `${name}[${k}] must be [x, y, z] or null`);
    }
  }

  // Fills in optional parts and checks shapes, so that later code can trust them.
  function normalize(data) {
    check(data && typeof data === 'object', 'top level must be an object');
    check(Array.isArray(data.time) && data.time.length > 0, '"time" must be a non-empty array');
    const n = data.time.length;
    data.time.forEach((t, k) => check(isNumber(t), `time[${k}] must be a number`));
    for (let k = 1; k < n; k++) {
      check(data.time[k] >= data.time[k - 1], `time must not decrease (time[${k}] < time[${k - 1}])`);
    }

    const robot = data.robot || {};
    const bodies = robot.bodies || [];
    const frames = robot.frames || [];
    check(Array.isArray(bodies) && Array.isArray(frames), 'robot.bodies and robot.frames must be arrays');
    bodies.forEach((b, i) => {
      check(Number.isInteger(b.parent) && b.parent >= -1 && b.parent < bodies.length && b.parent !== i,
        `robot.bodies[${i}].parent must be -1 or the index of another body`);
    });
    data.robot = { bodies, frames };
    data.body_pos = data.body_pos || [];
    data.frame_pos = data.frame_pos || [];
    data.frame_z = data.frame_z || [];
    if (bodies.length > 0) checkRows(data.body_pos, 'body_pos', n, 3 * bodies.length);
    if (frames.length > 0) {
      checkRows(data.frame_pos, 'frame_pos', n, 3 * frames.length);
      checkRows(data.frame_z, 'frame_z', n, 3 * frames.length);
    }

    data.targets = data.targets || [];
    data.targets.forEach((tg, i) => {
      check(tg.kind === 'position' || tg.kind === 'axis', `targets[${i}].kind must be "position" or "axis"`);
      check(tg.kind === 'position' || (Number.isInteger(tg.frame) && tg.frame >= 0 && tg.frame < frames.length),
        `targets[${i}].frame must index robot.frames`);
      checkOptionalVectors(tg.values, `targets[${i}].values`, n);
    });

    data.footprints = data.footprints || [];
    data.footprints.forEach((fp, i) => {
      check(isNumber(fp.t), `footprints[${i}].t must be a number`);
      check(fp.side === 'L' || fp.side === 'R', `footprints[${i}].side must be "L" or "R"`);
      check(Array.isArray(fp.polygon) && fp.polygon.length >= 2 &&
        fp.polygon.every((p) => Array.isArray(p) && p.length >= 2 && isNumber(p[0]) && isNumber(p[1])),
      `footprints[${i}].polygon must be a list of [x, y] points`);
    });

    data.paths = data.paths || [];
    data.paths.forEach((p, i) => checkOptionalVectors(p.points, `paths[${i}].points`, n));

    data.plots = data.plots || [];
    data.plots.forEach((plot, i) => {
      check(Array.isArray(plot.series), `plots[${i}].series must be an array`);
      plot.series.forEach((s, j) => {
        check(Array.isArray(s.values) && s.values.length === n,
          `plots[${i}].series[${j}].values must have ${n} entries`);
        s.values.forEach((v, k) => check(v === null || isNumber(v),
          `plots[${i}].series[${j}].values[${k}] must be a number or null`));
      });
    });

    data.summary = data.summary || [];
    check(Array.isArray(data.summary), '"summary" must be a list of [key, value] pairs');
    return data;
  }

  // Largest index k with time[k] <= t (0 if t is before the start).
  function indexAtTime(time, t) {
    let lo = 0;
    let hi = time.length - 1;
    if (t >= time[hi]) return hi;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (time[mid] <= t) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  }

  // ---------------------------------------------------------------- page text

  function renderHeader(data) {
    const title = data.title ? String(data.title) : 'Whole-body motion report';
    document.title = title;
    document.getElementById('title').textContent = title;
    const subtitle = document.getElementById('subtitle');
    if (data.subtitle) {
      subtitle.textContent = String(data.subtitle);
      subtitle.hidden = false;
    }
    const time = data.time;
    const duration = time[time.length - 1] - time[0];
    document.getElementById('meta').textContent = [
      `${time.length} samples`,
      `${duration.toFixed(3)} s`,
      `${data.robot.bodies.length} links`,
      `${data.robot.frames.length} frames`,
      `${data.targets.length} targets`,
    ].join(' · ');
  }

  function renderSummary(data) {
    if (data.summary.length === 0) return;
    const tbody = document.querySelector('#summary tbody');
    for (const entry of data.summary) {
      const row = document.createElement('tr');
      const pair = Array.isArray(entry) ? entry : [entry, ''];
      for (const [tag, value] of [['th', pair[0]], ['td', pair[1]]]) {
        const cell = document.createElement(tag);
        cell.textContent = typeof value === 'string' ? value : JSON.stringify(value);
        row.appendChild(cell);
      }
      tbody.appendChild(row);
    }
    document.getElementById('summary-section').hidden = false;
  }

  // ---------------------------------------------------------------- 3D view

  function standardMaterial(color, extra) {
    return new THREE.MeshStandardMaterial(Object.assign({ color, roughness: 0.55, metalness: 0.05 }, extra));
  }

  // An arrow along +Y of its group, from the origin to `length`.
  function makeArrow(length, color, scale = 1) {
    const material = standardMaterial(color);
    const headLength = 0.3 * length;
    const shaft = new THREE.Mesh(new THREE.CylinderGeometry(0.005 * scale, 0.005 * scale, length - headLength, 10),
      material);
    shaft.position.y = (length - headLength) / 2;
    const head = new THREE.Mesh(new THREE.ConeGeometry(0.013 * scale, headLength, 14), material);
    head.position.y = length - headLength / 2;
    const group = new THREE.Group();
    group.add(shaft, head);
    return group;
  }

  // Places an object whose local +Y is its axis so that the axis points along `dir`.
  function pointAlong(object, dir) {
    const len = dir.length();
    if (!(len > 1e-9)) return false;
    object.quaternion.setFromUnitVectors(Y_UP, dir.clone().divideScalar(len));
    return true;
  }

  function vecAt(row, index, out) {
    return out.set(row[3 * index], row[3 * index + 1], row[3 * index + 2]);
  }

  function rowIsFinite(row, index) {
    return isNumber(row[3 * index]) && isNumber(row[3 * index + 1]) && isNumber(row[3 * index + 2]);
  }

  // Bounding box (in robot coordinates) of the robot at sample k.
  function robotBox(data, k) {
    const box = new THREE.Box3();
    const p = new THREE.Vector3();
    const addRow = (row, count) => {
      for (let i = 0; i < count; i++) if (rowIsFinite(row, i)) box.expandByPoint(vecAt(row, i, p));
    };
    if (data.robot.bodies.length) addRow(data.body_pos[k], data.robot.bodies.length);
    if (data.robot.frames.length) addRow(data.frame_pos[k], data.robot.frames.length);
    return box;
  }

  // The robot's box at sample 0 (it sets the drawing scale), and the bounding sphere of the
  // robot over the whole run (the camera frames it): a robot that walks stays in view (a
  // sphere of sample 0 alone let NAO and a 0.26 m robot walk out of it).
  function robotBounds(data) {
    const box = robotBox(data, 0);
    if (box.isEmpty()) box.set(new THREE.Vector3(-0.5, -0.5, 0), new THREE.Vector3(0.5, 0.5, 1));
    const all = box.clone();
    const stride = Math.max(1, Math.floor(data.time.length / 200));
    for (let k = stride; k < data.time.length; k += stride) all.union(robotBox(data, k));
    all.union(robotBox(data, data.time.length - 1));
    const sphere = all.getBoundingSphere(new THREE.Sphere());
    sphere.radius = Math.max(sphere.radius, 0.3);
    return { box, sphere };
  }

  // Scale of the drawn links, spheres and arrows for the robot's height at sample 0.
  function drawingScale(box) {
    const height = box.max.z - box.min.z;
    if (!(height > 0)) return 1;
    return Math.min(MAX_DRAWING_SCALE, Math.max(MIN_DRAWING_SCALE, height / REFERENCE_HEIGHT));
  }

  // Extent of the floor grid: covers the robot, footprints and paths.
  function floorExtent(data, box) {
    let extent = Math.max(Math.abs(box.min.x), Math.abs(box.max.x), Math.abs(box.min.y), Math.abs(box.max.y));
    for (const fp of data.footprints) {
      for (const [x, y] of fp.polygon) extent = Math.max(extent, Math.abs(x), Math.abs(y));
    }
    for (const path of data.paths) {
      for (const p of path.points) if (p) extent = Math.max(extent, Math.abs(p[0]), Math.abs(p[1]));
    }
    return Math.min(Math.max(1, Math.ceil(extent + 0.5)), 50);
  }

  function createBodies(world, data, scale) {
    const bodies = data.robot.bodies;
    const jointGeometry = new THREE.SphereGeometry(JOINT_RADIUS * scale, 16, 12);
    const linkGeometry = new THREE.CylinderGeometry(LINK_RADIUS * scale, LINK_RADIUS * scale, 1, 14);
    const jointMaterial = standardMaterial(COLORS.joint);
    const linkMaterial = standardMaterial(COLORS.link);
    const joints = bodies.map(() => {
      const mesh = new THREE.Mesh(jointGeometry, jointMaterial);
      world.add(mesh);
      return mesh;
    });
    const links = bodies.map((body) => {
      if (body.parent < 0) return null;
      const mesh = new THREE.Mesh(linkGeometry, linkMaterial);
      world.add(mesh);
      return mesh;
    });
    const a = new THREE.Vector3();
    const b = new THREE.Vector3();
    const d = new THREE.Vector3();

    return function update(k) {
      if (bodies.length === 0) return;
      const row = data.body_pos[k];
      bodies.forEach((body, i) => {
        const ok = rowIsFinite(row, i);
        joints[i].visible = ok;
        if (ok) vecAt(row, i, joints[i].position);
        const link = links[i];
        if (!link) return;
        link.visible = false;
        if (!ok || !rowIsFinite(row, body.parent)) return;
        vecAt(row, body.parent, a);
        vecAt(row, i, b);
        d.subVectors(b, a);
        const len = d.length();
        if (len < MIN_LINK_LENGTH) return;
        link.position.addVectors(a, b).multiplyScalar(0.5);
        pointAlong(link, d);
        link.scale.set(1, len, 1);
        link.visible = true;
      });
    };
  }

  function createFrames(world, data, scale) {
    const frames = data.robot.frames;
    const sphereGeometry = new THREE.SphereGeometry(FRAME_SPHERE_RADIUS * scale, 14, 10);
    const material = standardMaterial(COLORS.frame);
    const items = frames.map(() => {
      const sphere = new THREE.Mesh(sphereGeometry, material);
      const arrow = makeArrow(FRAME_AXIS_LENGTH * scale, COLORS.frame, scale);
      world.add(sphere, arrow);
      return { sphere, arrow };
    });
    const z = new THREE.Vector3();

    return function update(k) {
      if (frames.length === 0) return;
      const pos = data.frame_pos[k];
      const axis = data.frame_z[k];
      items.forEach((item, i) => {
        const ok = rowIsFinite(pos, i);
        item.sphere.visible = ok;
        item.arrow.visible = false;
        if (!ok) return;
        vecAt(pos, i, item.sphere.position);
        item.arrow.position.copy(item.sphere.position);
        if (rowIsFinite(axis, i)) item.arrow.visible = pointAlong(item.arrow, vecAt(axis, i, z));
      });
    };
  }

  function createTargets(world, data, scale) {
    const sphereGeometry = new THREE.SphereGeometry(TARGET_SPHERE_RADIUS * scale, 20, 14);
    const sphereMaterial = standardMaterial(COLORS.targetPosition, {
      transparent: true, opacity: 0.45, depthWrite: false,
    });
    const objects = data.targets.map((target) => {
      const object = target.kind === 'position'
        ? new THREE.Mesh(sphereGeometry, sphereMaterial)
        : makeArrow(TARGET_AXIS_LENGTH * scale, COLORS.targetAxis, scale);
      object.visible = false;
      world.add(object);
      return object;
    });
    const dir = new THREE.Vector3();

    return function update(k) {
      data.targets.forEach((target, i) => {
        const object = objects[i];
        const value = target.values[k];
        object.visible = false;
        if (!value) return;
        if (target.kind === 'position') {
          object.position.set(value[0], value[1], value[2]);
          object.visible = true;
          return;
        }
        const origin = data.frame_pos[k];
        if (!rowIsFinite(origin, target.frame)) return;
        vecAt(origin, target.frame, object.position);
        object.visible = pointAlong(object, dir.set(value[0], value[1], value[2]));
      });
    };
  }

  function createFootprints(world, data) {
    const lines = data.footprints.map((fp) => {
      const points = fp.polygon.map(([x, y]) => new THREE.Vector3(x, y, FLOOR_LIFT));
      const color = fp.side === 'L' ? COLORS.footprintL : COLORS.footprintR;
      const line = new THREE.LineLoop(
        new THREE.BufferGeometry().setFromPoints(points),
        new THREE.LineBasicMaterial({ color }));
      world.add(line);
      return line;
    });
    return function update(k) {
      const t = data.time[k];
      data.footprints.forEach((fp, i) => { lines[i].visible = fp.t <= t; });
    };
  }

  // Each path is a LineSegments object whose segments are ordered by sample;
  // shownUpTo[k] is the number of segments that end at or before sample k.
  function createPaths(world, data) {
    const n = data.time.length;
    const items = data.paths.map((path, i) => {
      const positions = [];
      const shownUpTo = new Uint32Array(n);
      let segments = 0;
      for (let k = 1; k < n; k++) {
        const a = path.points[k - 1];
        const b = path.points[k];
        if (a && b) {
          positions.push(a[0], a[1], a[2], b[0], b[1], b[2]);
          segments++;
        }
        shownUpTo[k] = segments;
      }
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
      const line = new THREE.LineSegments(geometry,
        new THREE.LineBasicMaterial({ color: PATH_COLORS[i % PATH_COLORS.length] }));
      line.frustumCulled = false;
      world.add(line);
      return { line, shownUpTo };
    });
    return function update(k) {
      for (const item of items) item.line.geometry.setDrawRange(0, 2 * item.shownUpTo[k]);
    };
  }

  function createLegend(data) {
    const legend = document.getElementById('legend');
    const add = (color, text, shape) => {
      const row = document.createElement('div');
      row.className = 'legend-row';
      const swatch = document.createElement('span');
      swatch.className = 'swatch ' + (shape || 'box');
      swatch.style.background = hex(color);
      const label = document.createElement('span');
      label.textContent = text;
      row.append(swatch, label);
      legend.appendChild(row);
      return row;
    };
    if (data.robot.bodies.length) add(COLORS.link, 'links / body origins');
    if (data.robot.frames.length) {
      add(COLORS.frame, 'frames: ' + data.robot.frames.map((f) => f.name).join(', ') + ' (z-axis or task axis)');
    }
    const targetRows = data.targets.map((target) => add(
      target.kind === 'position' ? COLORS.targetPosition : COLORS.targetAxis,
      `target: ${target.name}`,
      target.kind === 'position' ? 'dot' : 'box'));
    if (data.footprints.some((fp) => fp.side === 'L')) add(COLORS.footprintL, 'left footprints', 'line');
    if (data.footprints.some((fp) => fp.side === 'R')) add(COLORS.footprintR, 'right footprints', 'line');
    data.paths.forEach((path, i) => add(PATH_COLORS[i % PATH_COLORS.length], `path: ${path.name}`, 'line'));
    legend.hidden = legend.childElementCount === 0;

    return function update(k) {
      data.targets.forEach((target, i) => {
        targetRows[i].classList.toggle('inactive', !target.values[k]);
      });
    };
  }

  function createView(container, data) {
    const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    renderer.domElement.id = 'view-canvas';
    container.prepend(renderer.domElement);

    const scene = new THREE.Scene();
    scene.background = new THREE.Color(COLORS.background);
    scene.add(new THREE.HemisphereLight(0xffffff, 0x8a96a8, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 2.2);
    sun.position.set(2, 5, 3);
    scene.add(sun);

    // The data are z-up; three.js is y-up. Everything from the data lives in
    // `world`, rotated so that data (x, y, z) shows at three.js (x, z, -y).
    const world = new THREE.Group();
    world.rotation.x = -Math.PI / 2;
    scene.add(world);
    world.updateMatrixWorld();

    const { box, sphere } = robotBounds(data);
    const scale = drawingScale(box);
    window.wbmDrawingScale = scale;  // for tests (web/test/check_report.mjs --expect-scale)
    const extent = floorExtent(data, box);
    const grid = new THREE.GridHelper(2 * extent, Math.min(20 * extent, 400), COLORS.gridCenter, COLORS.grid);
    scene.add(grid);
    world.add(new THREE.AxesHelper(0.3 * scale));

    const updates = [
      createBodies(world, data, scale),
      createFrames(world, data, scale),
      createTargets(world, data, scale),
      createFootprints(world, data),
      createPaths(world, data),
    ];

    const center = sphere.center.clone().applyMatrix4(world.matrixWorld);
    const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
    const controls = new THREE.OrbitControls(camera, renderer.domElement);
    controls.target.copy(center);

    function frameRobot() {
      const vfov = THREE.MathUtils.degToRad(camera.fov);
      const hfov = 2 * Math.atan(Math.tan(vfov / 2) * camera.aspect);
      const distance = 1.4 * sphere.radius / Math.sin(Math.min(vfov, hfov) / 2);
      const viewDir = new THREE.Vector3(1.0, -0.75, 0.35).normalize().applyMatrix4(
        new THREE.Matrix4().extractRotation(world.matrixWorld));
      camera.position.copy(center).addScaledVector(viewDir, distance);
      camera.near = distance / 100;
      camera.far = distance * 100 + 4 * extent;
      camera.updateProjectionMatrix();
      controls.update();
    }

    function render() {
      renderer.render(scene, camera);
    }

    function setSize() {
      const width = Math.max(container.clientWidth, 1);
      const height = Math.max(container.clientHeight, 1);
      renderer.setSize(width, height);
      camera.aspect = width / height;
      camera.updateProjectionMatrix();
    }

    setSize();
    frameRobot();
    // For tests (web/test/check_report.mjs): how many drawn body origins of sample k lie
    // outside the camera's view as the page framed it.
    window.wbmBodiesOutOfView = (k) => {
      camera.updateMatrixWorld();
      const frustum = new THREE.Frustum().setFromProjectionMatrix(
        new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse));
      const p = new THREE.Vector3();
      let out = 0;
      for (let i = 0; i < data.robot.bodies.length; i++) {
        if (!rowIsFinite(data.body_pos[k], i)) continue;
        if (!frustum.containsPoint(vecAt(data.body_pos[k], i, p).applyMatrix4(world.matrixWorld))) out++;
      }
      return out;
    };
    controls.addEventListener('change', render);
    renderer.domElement.addEventListener('dblclick', () => {
      frameRobot();
      render();
    });
    new ResizeObserver(() => {
      setSize();
      render();
    }).observe(container);

    return {
      update(k) {
        for (const update of updates) update(k);
      },
      render,
    };
  }

  // ---------------------------------------------------------------- plots

  // Min/max decimation to at most MAX_PLOT_POINTS points: two points per
  // bucket, in the order they occur. A bucket that is all null stays null; one
  // that is partly null gets a null second point, so gaps stay visible.
  function decimate(time, columns) {
    const n = time.length;
    if (n <= MAX_PLOT_POINTS) return [time, ...columns];
    const buckets = MAX_PLOT_POINTS / 2;
    const xs = [];
    const outs = columns.map(() => []);
    for (let b = 0; b < buckets; b++) {
      const i0 = Math.floor((b * n) / buckets);
      const i1 = Math.floor(((b + 1) * n) / buckets);
      xs.push(time[i0], time[i1 - 1]);
      columns.forEach((values, j) => {
        let min = Infinity;
        let max = -Infinity;
        let iMin = -1;
        let iMax = -1;
        let hasNull = false;
        for (let i = i0; i < i1; i++) {
          const v = values[i];
          if (v === null) { hasNull = true; continue; }
          if (v < min) { min = v; iMin = i; }
          if (v > max) { max = v; iMax = i; }
        }
        const out = outs[j];
        if (iMin < 0) out.push(null, null);
        else if (hasNull) out.push(iMin <= iMax ? min : max, null);
        else if (iMin <= iMax) out.push(min, max);
        else out.push(max, min);
      });
    }
    return [xs, ...outs];
  }

  function formatValue(v) {
    if (v === null || v === undefined) return '—';
    const a = Math.abs(v);
    return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(3) : v.toFixed(4);
  }

  // The value axis: uPlot's default (10 % padding, rounded, zero included when near), but
  // a plot whose values are all zero (a null-space cost while no joint is near a limit)
  // gets 0 to 1 instead of uPlot's 0 to 100, which suggested values up to 100.
  function valueRange(u, min, max) {
    if (min === 0 && max === 0) return [0, 1];
    return uPlot.rangeNum(min, max, 0.1, true);
  }

  function createPlots(container, data, onSeek) {
    const charts = [];
    const firstDraws = [];
    let syncingScale = false;

    data.plots.forEach((plot, p) => {
      const card = document.createElement('div');
      card.className = 'plot';
      container.appendChild(card);

      const cursorLine = document.createElement('div');
      cursorLine.className = 'time-cursor';
      let firstDrawDone;
      firstDraws.push(new Promise((resolve) => { firstDrawDone = resolve; }));

      const series = [{ label: 'time (s)', value: (u, v) => (v === null ? '—' : v.toFixed(3)) }];
      plot.series.forEach((s, j) => {
        series.push({
          label: String(s.label),
          stroke: SERIES_COLORS[j % SERIES_COLORS.length],
          dash: SERIES_DASHES[Math.floor(j / SERIES_COLORS.length) % SERIES_DASHES.length],
          width: 1.5,
          value: (u, v) => formatValue(v),
        });
      });

      const chart = { plot, u: null, cursorLine, time: data.time[0] };
      const options = {
        title: plot.title ? String(plot.title) : `Plot ${p + 1}`,
        width: Math.max(card.clientWidth, 200),
        height: PLOT_HEIGHT,
        scales: { x: { time: false }, y: { range: valueRange } },
        series,
        axes: [
          { label: 'time (s)' },
          { label: plot.unit ? String(plot.unit) : '', size: 60 },
        ],
        cursor: { sync: { key: 'wbm-time' } },
        hooks: {
          draw: [(u) => { placeCursor(chart, u); firstDrawDone(); }],
          setCursor: [(u) => showLegendAtTime(chart, u)],
          setScale: [(u, key) => {
            if (key !== 'x' || syncingScale) return;
            syncingScale = true;
            for (const other of charts) {
              if (other.u && other.u !== u) other.u.setScale('x', { min: u.scales.x.min, max: u.scales.x.max });
            }
            syncingScale = false;
          }],
        },
      };
      const columns = plot.series.map((s) => s.values);
      chart.u = new uPlot(options, decimate(data.time, columns), card);
      chart.u.over.appendChild(cursorLine);
      charts.push(chart);

      let downX = null;
      chart.u.over.addEventListener('mousedown', (e) => { downX = e.clientX; });
      chart.u.over.addEventListener('click', (e) => {
        if (downX === null || Math.abs(e.clientX - downX) > 3) return;
        const left = e.clientX - chart.u.over.getBoundingClientRect().left;
        onSeek(chart.u.posToVal(left, 'x'));
      });

      new ResizeObserver(() => {
        const width = Math.max(card.clientWidth, 200);
        if (width !== chart.u.width) chart.u.setSize({ width, height: PLOT_HEIGHT });
      }).observe(card);
    });

    function placeCursor(chart, u = chart.u) {
      const x = u.valToPos(chart.time, 'x');
      const visible = Number.isFinite(x) && x >= 0 && x <= u.over.clientWidth;
      chart.cursorLine.style.display = visible ? 'block' : 'none';
      if (visible) chart.cursorLine.style.transform = `translateX(${x}px)`;
    }

    // While the mouse is not over a chart, its legend shows the values at the
    // current animation time.
    function showLegendAtTime(chart, u = chart.u) {
      if (u.cursor.left >= 0) return;
      u.setLegend({ idx: indexAtTime(u.data[0], chart.time) }, false);
    }

    return {
      setTime(t) {
        for (const chart of charts) {
          chart.time = t;
          placeCursor(chart);
          showLegendAtTime(chart);
        }
      },
      drawn: Promise.all(firstDraws),
      valueRanges: () => charts.map((chart) => [chart.u.scales.y.min, chart.u.scales.y.max]),
    };
  }

  // ---------------------------------------------------------------- player

  function createPlayer(data, view, plots, legendUpdate) {
    const time = data.time;
    const last = time.length - 1;
    const slider = document.getElementById('time-slider');
    const label = document.getElementById('time-label');
    const button = document.getElementById('play-button');
    const speedSelect = document.getElementById('speed-select');
    const digits = last > 0 && time[last] - time[0] < 100 ? 3 : 2;
    const end = time[last].toFixed(digits);

    slider.max = String(last);
    let index = -1;
    let playing = false;
    let playTime = time[0];
    let lastFrame = 0;

    function show(k) {
      k = Math.min(Math.max(k, 0), last);
      if (k === index) return;
      index = k;
      view.update(k);
      view.render();
      legendUpdate(k);
      plots.setTime(time[k]);
      slider.value = String(k);
      label.textContent = `t = ${time[k].toFixed(digits)} s / ${end} s`;
    }

    function setPlaying(on) {
      playing = on && last > 0;
      button.textContent = playing ? 'Pause' : 'Play';
      button.classList.toggle('playing', playing);
      if (!playing) return;
      if (index >= last) show(0);
      playTime = time[index];
      lastFrame = performance.now();
      requestAnimationFrame(tick);
    }

    function tick(now) {
      if (!playing) return;
      const speed = Number(speedSelect.value) || 1;
      playTime += ((now - lastFrame) / 1000) * speed;
      lastFrame = now;
      if (playTime > time[last]) playTime = time[0] + (playTime - time[last]) % Math.max(time[last] - time[0], 1e-9);
      show(indexAtTime(time, playTime));
      requestAnimationFrame(tick);
    }

    function seekIndex(k) {
      show(k);
      playTime = time[index];
    }

    slider.addEventListener('input', () => seekIndex(Number(slider.value)));
    button.addEventListener('click', () => setPlaying(!playing));
    document.addEventListener('keydown', (e) => {
      const tag = e.target && e.target.tagName;
      if (tag === 'INPUT' || tag === 'SELECT' || tag === 'BUTTON' || tag === 'TEXTAREA') return;
      if (e.key === ' ') { e.preventDefault(); setPlaying(!playing); }
      else if (e.key === 'ArrowRight') seekIndex(index + 1);
      else if (e.key === 'ArrowLeft') seekIndex(index - 1);
    });

    show(0);
    return { seekTime: (t) => seekIndex(indexAtTime(time, t)) };
  }

  // ---------------------------------------------------------------- main

  function main() {
    const data = normalize(readData());
    renderHeader(data);
    renderSummary(data);
    const legendUpdate = createLegend(data);
    const view = createView(document.getElementById('view'), data);

    let player = null;
    if (data.plots.length) document.getElementById('plots-section').hidden = false;
    const plots = createPlots(document.getElementById('plots'), data, (t) => player && player.seekTime(t));
    player = createPlayer(data, view, plots, legendUpdate);
    window.wbmPlotValueRanges = plots.valueRanges;  // for tests (web/test/check_report.mjs)

    plots.drawn.then(() => requestAnimationFrame(() => { window.wbmReady = true; }));
  }

  try {
    main();
  } catch (err) {
    console.error(err);
    showError(err);
  }
})();
