// Synthetic but plausible report data: a stick-figure humanoid (21 bodies)
// that steps forward and waves its right arm, with a hand position target, a
// gaze axis target, footprints, paths and two plots.
//
//   makeSampleData()                       3 s at 100 Hz
//   makeSampleData({ variant: 'large' })   50 s at 100 Hz (N = 5000), 41 bodies, 30 plot series
//   makeSampleData({ variant: 'minimal' }) only the required fields, no frames or targets

const LEG = 0.42;

const round = (x) => Math.round(x * 1e5) / 1e5;
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const norm = (a) => Math.sqrt(dot(a, a));
const unit = (a) => scale(a, 1 / norm(a));
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const lerp = (a, b, s) => add(scale(a, 1 - s), scale(b, s));

function smoothstep(t0, t1, t) {
  const s = Math.min(Math.max((t - t0) / (t1 - t0), 0), 1);
  return s * s * (3 - 2 * s);
}

const BODIES = [
  ['pelvis', -1], ['torso', 0], ['chest', 1], ['neck', 2], ['head', 3],
  ['l_shoulder', 2], ['l_elbow', 5], ['l_wrist', 6], ['l_hand', 7],
  ['r_shoulder', 2], ['r_elbow', 9], ['r_wrist', 10], ['r_hand', 11],
  ['l_hip', 0], ['l_knee', 13], ['l_ankle', 14], ['l_toe', 15],
  ['r_hip', 0], ['r_knee', 17], ['r_ankle', 18], ['r_toe', 19],
];
const BODY = Object.fromEntries(BODIES.map(([name], i) => [name, i]));

// Foot placement: each foot steps 0.2 m forward once (right, then left).
function foot(side, t) {
  const [t0, t1] = side === 'R' ? [0.8, 1.4] : [1.8, 2.4];
  const s = smoothstep(t0, t1, t);
  const lift = t > t0 && t < t1 ? 0.06 * Math.sin((Math.PI * (t - t0)) / (t1 - t0)) : 0;
  return [0.2 * s, side === 'L' ? 0.1 : -0.1, 0.08 + lift];
}

// Knee of a two-link leg, bent forward (+x).
function knee(hip, ankle) {
  const d = sub(ankle, hip);
  const len = norm(d);
  const h = Math.sqrt(Math.max(LEG * LEG - (len / 2) ** 2, 0));
  const forward = unit(sub([1, 0, 0], scale(d, d[0] / (len * len))));
  return add(scale(add(hip, ankle), 0.5), scale(forward, h));
}

// Right upper-arm and forearm directions: raise the arm, wave, lower it.
function rightArm(t) {
  const raise = smoothstep(0.3, 1.0, t) * (1 - smoothstep(2.4, 3.0, t));
  const a = 0.15 + 2.0 * raise;
  const upper = [0.08, -Math.sin(a), -Math.cos(a)];
  const wave = 0.55 * raise * Math.sin(2 * Math.PI * 1.2 * t);
  const elbow = raise * (Math.PI - 0.1) + wave;
  const forearm = unit([0.15, -Math.sin(elbow), -Math.cos(elbow)]);
  return { upper: unit(upper), forearm, abduction: a };
}

function pose(t) {
  const lf = foot('L', t);
  const rf = foot('R', t);
  const sway = 0.03 * Math.sin(Math.PI * smoothstep(0.4, 2.6, t) * 2);
  const pelvis = [0.5 * (lf[0] + rf[0]) + 0.02, sway, 0.93];
  const p = {};
  p.pelvis = pelvis;
  p.torso = add(pelvis, [0, 0, 0.2]);
  p.chest = add(p.torso, [0.01, 0, 0.24]);
  p.neck = add(p.chest, [0, 0, 0.12]);
  p.head = add(p.neck, [0.01, 0, 0.13]);

  p.l_shoulder = add(p.chest, [0, 0.18, 0.04]);
  p.l_elbow = add(p.l_shoulder, [0.02, 0.03, -0.28]);
  p.l_wrist = add(p.l_elbow, [0.07, 0, -0.24]);
  p.l_hand = add(p.l_wrist, [0.02, 0, -0.08]);

  const arm = rightArm(t);
  p.r_shoulder = add(p.chest, [0, -0.18, 0.04]);
  p.r_elbow = add(p.r_shoulder, scale(arm.upper, 0.28));
  p.r_wrist = add(p.r_elbow, scale(arm.forearm, 0.25));
  p.r_hand = add(p.r_wrist, scale(arm.forearm, 0.08));

  for (const [side, f] of [['l', lf], ['r', rf]]) {
    const hip = add(pelvis, [0, side === 'l' ? 0.09 : -0.09, -0.06]);
    p[`${side}_hip`] = hip;
    p[`${side}_ankle`] = f;
    p[`${side}_knee`] = knee(hip, f);
    p[`${side}_toe`] = add(f, [0.14, 0, -0.07]);
  }
  return { p, arm };
}

function kneeAngle(p, side) {
  const thigh = unit(sub(p[`${side}_knee`], p[`${side}_hip`]));
  const shin = unit(sub(p[`${side}_ankle`], p[`${side}_knee`]));
  return Math.acos(Math.min(Math.max(dot(thigh, shin), -1), 1));
}

// Extra finger bodies for the large variant: 5 fingers x 2 phalanges per hand.
function fingerBodies() {
  const extra = [];
  for (const side of ['l', 'r']) {
    for (let f = 0; f < 5; f++) {
      const base = BODIES.length + extra.length;
      extra.push([`${side}_finger${f}_1`, BODY[`${side}_hand`]]);
      extra.push([`${side}_finger${f}_2`, base]);
    }
  }
  return extra;
}

function fingerPositions(p) {
  const out = [];
  for (const side of ['l', 'r']) {
    const dir = unit(sub(p[`${side}_hand`], p[`${side}_wrist`]));
    const across = unit(cross(dir, Math.abs(dir[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0]));
    for (let f = 0; f < 5; f++) {
      const spread = (f - 2) * 0.012;
      const p1 = add(add(p[`${side}_hand`], scale(dir, 0.04)), scale(across, spread));
      const p2 = add(p1, scale(dir, 0.03));
      out.push(p1, p2);
    }
  }
  return out;
}

function rectangle(cx, cy) {
  return [[cx - 0.07, cy - 0.045], [cx + 0.16, cy - 0.045], [cx + 0.16, cy + 0.045], [cx - 0.07, cy + 0.045]]
    .map(([x, y]) => [round(x), round(y)]);
}

export function makeSampleData({ variant = 'default' } = {}) {
  const large = variant === 'large';
  const minimal = variant === 'minimal';
  const rate = 100;
  const n = large ? 5000 : 301;
  const time = Array.from({ length: n }, (_, k) => round(k / rate));
  const motionTime = (t) => (large ? t % 3 : t);

  const bodies = large ? BODIES.concat(fingerBodies()) : BODIES;
  const frames = minimal ? [] : [{ name: 'r_hand_grasp' }, { name: 'head_camera' }];

  const bodyPos = [];
  const framePos = [];
  const frameZ = [];
  const handTarget = [];
  const gazeTarget = [];
  const angles = { r_shoulder_abd: [], r_elbow: [], l_knee: [], r_knee: [], head_yaw: [] };
  const errors = { 'r_hand position error': [], 'gaze axis error': [] };
  const heel = [];
  const com = [];

  for (let k = 0; k < n; k++) {
    const t = motionTime(time[k]);
    const { p, arm } = pose(t);
    const points = BODIES.map(([name]) => p[name]);
    if (large) points.push(...fingerPositions(p));
    bodyPos.push(points.flat().map(round));

    const handActive = t >= 0.5 && t < 2.6;
    const desired = pose(Math.min(t + 0.025, 3)).p.r_hand;
    handTarget.push(handActive ? desired.map(round) : null);

    const eye = add(p.head, [0.08, 0, 0.02]);
    const lookAt = unit(sub(pose(Math.max(t - 0.1, 0)).p.r_hand, eye));
    const gazeActive = t >= 1.0 && !(t >= 1.9 && t < 2.1);
    const gazeWant = unit(sub(desired, eye));
    const gaze = unit(lerp([1, 0, -0.15], lookAt, smoothstep(0.7, 1.1, t)));
    gazeTarget.push(gazeActive ? gazeWant.map(round) : null);

    framePos.push([...p.r_hand, ...eye].map(round));
    frameZ.push([...arm.forearm, ...gaze].map(round));

    angles.r_shoulder_abd.push(round(arm.abduction));
    angles.r_elbow.push(round(Math.acos(Math.min(dot(arm.upper, arm.forearm), 1))));
    angles.l_knee.push(round(kneeAngle(p, 'l')));
    angles.r_knee.push(round(kneeAngle(p, 'r')));
    angles.head_yaw.push(round(Math.atan2(gaze[1], gaze[0])));
    errors['r_hand position error'].push(handActive ? round(norm(sub(desired, p.r_hand))) : null);
    errors['gaze axis error'].push(gazeActive ? round(Math.acos(Math.min(dot(gaze, gazeWant), 1))) : null);
    heel.push(add(p.r_ankle, [-0.05, 0, -0.08]).map(round));
    com.push(add(p.pelvis, [0, 0, 0.1]).map(round));
  }

  const data = {
    title: large ? 'Sample: long wave (large data)' : 'Sample: step and wave',
    time,
    robot: { bodies: bodies.map(([name, parent]) => ({ name, parent })) },
    body_pos: bodyPos,
    plots: [
      {
        title: 'Joint angles',
        unit: 'rad',
        series: Object.entries(angles).map(([label, values]) => ({ label, values })),
      },
    ],
  };
  if (minimal) return data;

  data.subtitle = 'Synthetic data from test/sample_data.mjs </script><!-- escaped';
  data.robot.frames = frames;
  data.frame_pos = framePos;
  data.frame_z = frameZ;
  data.targets = [
    { name: 'r_hand position', kind: 'position', frame: 0, values: handTarget },
    { name: 'head_camera gaze', kind: 'axis', frame: 1, values: gazeTarget },
  ];
  data.footprints = [
    { t: 0, side: 'L', polygon: rectangle(0, 0.1) },
    { t: 0, side: 'R', polygon: rectangle(0, -0.1) },
    { t: 1.4, side: 'R', polygon: rectangle(0.2, -0.1) },
    { t: 2.4, side: 'L', polygon: rectangle(0.2, 0.1) },
  ];
  data.paths = [
    { name: 'r_heel', points: heel },
    { name: 'CoM', points: com },
  ];
  data.plots.push({
    title: 'Tracking errors',
    unit: 'm, rad',
    series: Object.entries(errors).map(([label, values]) => ({ label, values })),
  });
  if (large) {
    for (let j = data.plots[0].series.length; j < 30; j++) {
      data.plots[0].series.push({
        label: `q${j}`,
        values: time.map((t, k) => (j % 7 === 0 && k % 1000 > 900 ? null : round(0.3 * Math.sin(0.7 * t + j) + 0.05 * j))),
      });
    }
  }
  data.summary = [
    ['controller', 'whole-body QP (synthetic)'],
    ['samples', String(n)],
    ['duration', `${time[n - 1].toFixed(2)} s`],
    ['max r_hand position error', `${Math.max(...errors['r_hand position error'].filter((v) => v !== null)).toFixed(4)} m`],
    ['footsteps', '2'],
    ['note', 'escaping test: </script><!-- & "quotes"'],
  ];
  return data;
}
