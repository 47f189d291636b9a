// The 3D view: a three.js scene with a floor grid at y = 0 and an orbit
// camera in which each figure is a skeleton (a sphere per joint, a line per
// bone) played at its motion's frame rate. Figures stand side by side, or on
// the same spot when overlaid. A figure with a root path (root_path.js: a
// motion the server generated) travels along it, the camera following, and
// a top-down inset in the view's corner draws those paths. A figure may
// mark a span of its frames (a take's filled gap) by drawing them in another
// colour. Units are millimetres, y up (the FK's axes).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { drawRootInset } from './root_path.js';

const FIGURE_SPACING_MM = 1100;
// The FK puts the hips at the origin; a figure without a root path stands
// there, lifted so that its feet (about 900 mm below the hips) touch the grid.
const STANDING_ROOT_MM = [0, 930, 0];
const JOINT_RADIUS_MM = 18;
// The floor: 8 m square in cells of 500 mm, about the point the camera
// follows, moved by whole cells so that its lines stay put under a walking
// figure. A floor wide enough for any walk would pass behind the camera,
// where software WebGL (SwiftShader, the browser test's) drops whole lines.
const FLOOR_SIZE_MM = 8000;
const FLOOR_CELL_MM = 500;
// The camera's target eases towards the figures' roots with this time
// constant, so that it follows a walk without the jitter of every step.
const FOLLOW_SECONDS = 0.4;

export const FIGURE_COLOURS = ['#4f9dff', '#ff8a3d', '#4fd18b', '#e05dd6', '#f2d14a', '#9aa4b2'];

class Figure {
  // positions: one Float64Array (joints x 3, mm, the root at the origin) per
  // frame; parents[j] < j; rootPath: [x, y, z] (mm) of the root per frame, or
  // null to stand at the origin; marked: { first, last, colour, label } to
  // draw frames first..last (inclusive) in that colour (with spans: [{ first,
  // last }], the frames of those spans only, first..last their extent), or
  // null.
  constructor(scene, { label, positions, parents, frameRate, colour, rootPath = null, marked = null }) {
    this.label = label;
    this.frameRate = frameRate;
    this.parents = parents;
    this.colour = colour;
    this.marked = marked;
    this.laneX = 0;  // the side-by-side offset, arrange()'s
    this.root = STANDING_ROOT_MM;  // where the root is drawn at the frame shown
    this.group = new THREE.Group();
    this.jointMaterial = new THREE.MeshStandardMaterial({ color: colour, roughness: 0.5 });
    this.boneMaterial = new THREE.LineBasicMaterial({ color: colour });
    const material = this.jointMaterial;
    const sphere = new THREE.SphereGeometry(JOINT_RADIUS_MM, 12, 8);
    this.joints = parents.map(() => {
      const joint = new THREE.Mesh(sphere, material);
      this.group.add(joint);
      return joint;
    });
    const bonePairs = parents.filter((p) => p >= 0).length;
    this.boneGeometry = new THREE.BufferGeometry();
    this.boneGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(bonePairs * 6), 3));
    this.group.add(new THREE.LineSegments(this.boneGeometry, this.boneMaterial));
    scene.add(this.group);
    this.setPositions(positions, label, rootPath);
  }

  setPositions(positions, label, rootPath = null) {
    this.positions = positions;
    this.label = label;
    this.rootPath = rootPath;
  }

  get frameCount() { return this.positions.length; }

  // Poses the figure at `frame` (its last frame when the motion is shorter).
  pose(frame) {
    const last = Math.min(frame, this.positions.length - 1);
    const p = this.positions[last];
    this.root = this.rootPath ? this.rootPath[last] : STANDING_ROOT_MM;
    this.place();
    const inMarked = this.marked && (this.marked.spans ?? [this.marked]).some((span) => last >= span.first && last <= span.last);
    const colour = inMarked ? this.marked.colour : this.colour;
    this.jointMaterial.color.set(colour);
    this.boneMaterial.color.set(colour);
    this.joints.forEach((joint, j) => joint.position.set(p[3 * j], p[3 * j + 1], p[3 * j + 2]));
    const bones = this.boneGeometry.attributes.position;
    let k = 0;
    this.parents.forEach((parent, j) => {
      if (parent < 0) return;
      bones.setXYZ(k++, p[3 * parent], p[3 * parent + 1], p[3 * parent + 2]);
      bones.setXYZ(k++, p[3 * j], p[3 * j + 1], p[3 * j + 2]);
    });
    bones.needsUpdate = true;
  }

  // The joints are drawn about the root, so the whole figure moves with it.
  place() {
    this.group.position.set(this.laneX + this.root[0], this.root[1], this.root[2]);
  }

  dispose(scene) {
    scene.remove(this.group);
    this.boneGeometry.dispose();
    this.jointMaterial.dispose();
    this.boneMaterial.dispose();
  }
}

export class SkeletonView {
  // `elements`: the canvas's container, the play button, the frame slider,
  // the frame label and the legend.
  constructor({ container, playButton, slider, frameLabel, legend, overlayBox }) {
    Object.assign(this, { container, playButton, slider, frameLabel, legend, overlayBox });
    this.figures = [];
    this.frameListeners = [];  // called with the frame shown, at every change
    this.frame = 0;
    this.playing = false;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    container.append(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#15181d');
    this.scene.add(new THREE.HemisphereLight('#ffffff', '#445', 2.5));
    const sun = new THREE.DirectionalLight('#ffffff', 1.5);
    sun.position.set(2000, 4000, 3000);
    this.scene.add(sun);
    this.floor = new THREE.GridHelper(FLOOR_SIZE_MM, FLOOR_SIZE_MM / FLOOR_CELL_MM, '#556', '#333a44');
    this.scene.add(this.floor);
    this.camera = new THREE.PerspectiveCamera(40, 1, 10, 50000);
    this.camera.position.set(2600, 1900, 4200);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.target.set(0, 900, 0);
    this.controls.update();
    // Where the camera follows to (x, z: the mean of the figures' roots) as
    // far as it has got; what the user pans stays on top of it.
    this.followed = { x: 0, z: 0 };
    this.lastTick = null;
    this.inset = document.createElement('canvas');
    this.inset.id = 'root-inset';
    this.inset.width = this.inset.height = 180;
    this.inset.hidden = true;
    container.append(this.inset);

    playButton.addEventListener('click', () => (this.playing ? this.pause() : this.play()));
    slider.addEventListener('input', () => {
      this.pause();
      this.setFrame(Number(slider.value));
    });
    overlayBox.addEventListener('change', () => this.arrange());
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
    this.renderer.setAnimationLoop((time) => this.tick(time));
  }

  // Replaces the figures: [{label, positions, parents, frameRate, rootPath,
  // marked}] (rootPath and marked optional, as Figure's), and plays; what listened to the frame of the
  // figures before stops.
  show(figures) {
    this.frameListeners = [];
    this.figures.forEach((f) => f.dispose(this.scene));
    this.figures = figures.map((f, i) => new Figure(this.scene, { colour: FIGURE_COLOURS[i % FIGURE_COLOURS.length], ...f }));
    this.inset.hidden = !this.figures.some((f) => f.rootPath);
    this.arrange();
    this.slider.max = String(Math.max(0, this.frameCount - 1));
    this.setFrame(0);
    this.play();
  }

  // Gives figure `index` other positions and root path (the interpolation
  // slider), keeping the frame.
  replacePositions(index, positions, label, rootPath = null) {
    this.figures[index].setPositions(positions, label, rootPath);
    this.inset.hidden = !this.figures.some((f) => f.rootPath);
    this.renderLegend();
    this.setFrame(this.frame);
  }

  get frameCount() { return Math.max(0, ...this.figures.map((f) => f.frameCount)); }
  get frameRate() { return this.figures[0]?.frameRate ?? 25; }

  arrange() {
    const overlay = this.overlayBox.checked;
    const offset = (this.figures.length - 1) / 2;
    this.figures.forEach((f, i) => {
      f.laneX = overlay ? 0 : (i - offset) * FIGURE_SPACING_MM;
      f.place();
    });
    this.renderLegend();
  }

  renderLegend() {
    const item = (colour, text) => {
      const span = document.createElement('span');
      span.style.color = colour;
      span.textContent = `■ ${text}`;
      return span;
    };
    this.legend.replaceChildren(...this.figures.flatMap((f) => [item(f.colour, f.label),
                                                                ...(f.marked ? [item(f.marked.colour, f.marked.label)] : [])]));
  }

  play() {
    if (!this.figures.length) return;
    this.playing = true;
    this.playStart = null;
    this.playButton.textContent = 'Pause';
  }

  pause() {
    this.playing = false;
    this.playButton.textContent = 'Play';
  }

  setFrame(frame) {
    this.frame = frame;
    this.figures.forEach((f) => f.pose(frame));
    this.slider.value = String(frame);
    this.frameLabel.textContent = `frame ${frame + 1} / ${this.frameCount} at ${this.frameRate} Hz`;
    this.drawInset();
    this.frameListeners.forEach((listener) => listener(frame));
  }

  // The travelling figures' paths from above, from a common start whatever
  // their lanes here; a standing figure's would be a dot at the origin.
  drawInset() {
    if (this.inset.hidden) return;
    drawRootInset(this.inset, this.figures.filter((f) => f.rootPath)
      .map((f) => ({ colour: f.colour, points: f.rootPath, frame: this.frame })));
  }

  // Moves the orbit target, and the camera with it (keeping the angle and
  // distance the user chose), a step towards the mean of the figures' roots
  // on the floor, and the floor after them: a figure standing at the origin
  // counts as 0, so the view eases back when travelling figures give way to
  // standing ones.
  follow(seconds) {
    if (!this.figures.length) return;
    const mean = (axis) => this.figures.reduce((sum, f) => sum + f.root[axis], 0) / this.figures.length;
    const ease = 1 - Math.exp(-seconds / FOLLOW_SECONDS);
    const step = { x: (mean(0) - this.followed.x) * ease, z: (mean(2) - this.followed.z) * ease };
    this.followed.x += step.x;
    this.followed.z += step.z;
    for (const point of [this.controls.target, this.camera.position]) {
      point.x += step.x;
      point.z += step.z;
    }
    const wholeCells = (mm) => Math.round(mm / FLOOR_CELL_MM) * FLOOR_CELL_MM;
    this.floor.position.set(wholeCells(this.followed.x), 0, wholeCells(this.followed.z));
  }

  // Pauses and shows `frame` (a click on a take's strip or error plot).
  seek(frame) {
    this.pause();
    this.setFrame(Math.max(0, Math.min(this.frameCount - 1, frame)));
  }

  tick(time) {
    const seconds = this.lastTick === null ? 0 : (time - this.lastTick) / 1000;
    this.lastTick = time;
    if (this.playing && this.frameCount > 0) {
      // Playback continues from the frame shown when play was pressed.
      if (this.playStart === null) this.playStart = time - (this.frame / this.frameRate) * 1000;
      const frame = Math.floor(((time - this.playStart) / 1000) * this.frameRate) % this.frameCount;
      if (frame !== this.frame) this.setFrame(frame);
    }
    this.follow(seconds);
    this.controls.update();
    this.renderer.render(this.scene, this.camera);
  }

  resize() {
    const { clientWidth: width, clientHeight: height } = this.container;
    if (!width || !height) return;
    this.renderer.setSize(width, height);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
  }

  // What the view draws, for the browser test: each figure's label, joint
  // count and frame count, the joint positions (mm, relative to its hips) of
  // the spheres as they stand now, whether it travels (has a root path) and
  // where its root is drawn now (mm, its lane's offset taken off; a standing
  // figure's is STANDING_ROOT_MM); the colour its joints and bones are drawn
  // in now ('#rrggbb', the materials' own) and its marked span; whether the
  // inset shows.
  describe() {
    return {
      frame: this.frame,
      playing: this.playing,
      insetShown: !this.inset.hidden,
      figures: this.figures.map((f) => ({
        label: f.label,
        joints: f.joints.length,
        frames: f.frameCount,
        drawnPositionsMm: f.joints.map((j) => [j.position.x, j.position.y, j.position.z]),
        travels: Boolean(f.rootPath),
        rootMm: [f.group.position.x - f.laneX, f.group.position.y, f.group.position.z],
        jointColour: `#${f.jointMaterial.color.getHexString()}`,
        boneColour: `#${f.boneMaterial.color.getHexString()}`,
        marked: f.marked && { first: f.marked.first, last: f.marked.last, spans: f.marked.spans ?? null, colour: f.marked.colour },
      })),
    };
  }
}
