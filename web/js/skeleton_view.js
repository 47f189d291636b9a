// The 3D view: a three.js scene with a ground grid and an orbit camera in
// which each figure is a skeleton (a sphere per joint, a line per bone)
// played at its motion's frame rate. Figures stand side by side, or on the
// same spot when overlaid. Units are millimetres, y up (the FK's axes).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const FIGURE_SPACING_MM = 1100;
// The FK puts the hips at the origin; this lifts a standing figure's feet
// (about 900 mm below the hips) onto the grid.
const HIP_HEIGHT_MM = 930;
const JOINT_RADIUS_MM = 18;

export const FIGURE_COLOURS = ['#4f9dff', '#ff8a3d', '#4fd18b', '#e05dd6', '#f2d14a', '#9aa4b2'];

class Figure {
  // positions: one Float64Array (joints x 3, mm) per frame; parents[j] < j.
  constructor(scene, { label, positions, parents, frameRate, colour }) {
    this.label = label;
    this.frameRate = frameRate;
    this.parents = parents;
    this.group = new THREE.Group();
    this.group.position.y = HIP_HEIGHT_MM;
    const material = new THREE.MeshStandardMaterial({ color: colour, roughness: 0.5 });
    const sphere = new THREE.SphereGeometry(JOINT_RADIUS_MM, 12, 8);
    this.joints = parents.map(() => {
      const joint = new THREE.Mesh(sphere, material);
      this.group.add(joint);
      return joint;
    });
    const bonePairs = parents.filter((p) => p >= 0).length;
    this.boneGeometry = new THREE.BufferGeometry();
    this.boneGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(bonePairs * 6), 3));
    this.group.add(new THREE.LineSegments(this.boneGeometry, new THREE.LineBasicMaterial({ color: colour })));
    scene.add(this.group);
    this.setPositions(positions, label);
  }

  setPositions(positions, label) {
    this.positions = positions;
    this.label = label;
  }

  get frameCount() { return this.positions.length; }

  // Poses the figure at `frame` (its last frame when the motion is shorter).
  pose(frame) {
    const p = this.positions[Math.min(frame, this.positions.length - 1)];
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

  dispose(scene) {
    scene.remove(this.group);
    this.boneGeometry.dispose();
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
    this.scene.add(new THREE.GridHelper(8000, 16, '#556', '#333a44'));
    this.camera = new THREE.PerspectiveCamera(40, 1, 10, 50000);
    this.camera.position.set(2600, 1900, 4200);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.target.set(0, 900, 0);
    this.controls.update();

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

  // Replaces the figures: [{label, positions, parents, frameRate}], and
  // plays; what listened to the frame of the figures before stops.
  show(figures) {
    this.frameListeners = [];
    this.figures.forEach((f) => f.dispose(this.scene));
    this.figures = figures.map((f, i) => new Figure(this.scene, { colour: FIGURE_COLOURS[i % FIGURE_COLOURS.length], ...f }));
    this.arrange();
    this.slider.max = String(Math.max(0, this.frameCount - 1));
    this.setFrame(0);
    this.play();
  }

  // Gives figure `index` other positions (the interpolation slider), keeping the frame.
  replacePositions(index, positions, label) {
    this.figures[index].setPositions(positions, label);
    this.renderLegend();
    this.setFrame(this.frame);
  }

  get frameCount() { return Math.max(0, ...this.figures.map((f) => f.frameCount)); }
  get frameRate() { return this.figures[0]?.frameRate ?? 25; }

  arrange() {
    const overlay = this.overlayBox.checked;
    const offset = (this.figures.length - 1) / 2;
    this.figures.forEach((f, i) => (f.group.position.x = overlay ? 0 : (i - offset) * FIGURE_SPACING_MM));
    this.renderLegend();
  }

  renderLegend() {
    this.legend.replaceChildren(...this.figures.map((f, i) => {
      const item = document.createElement('span');
      item.style.color = FIGURE_COLOURS[i % FIGURE_COLOURS.length];
      item.textContent = `■ ${f.label}`;
      return item;
    }));
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
    this.frameListeners.forEach((listener) => listener(frame));
  }

  // Pauses and shows `frame` (a click on a take's strip or error plot).
  seek(frame) {
    this.pause();
    this.setFrame(Math.max(0, Math.min(this.frameCount - 1, frame)));
  }

  tick(time) {
    if (this.playing && this.frameCount > 0) {
      // Playback continues from the frame shown when play was pressed.
      if (this.playStart === null) this.playStart = time - (this.frame / this.frameRate) * 1000;
      const frame = Math.floor(((time - this.playStart) / 1000) * this.frameRate) % this.frameCount;
      if (frame !== this.frame) this.setFrame(frame);
    }
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
  // count and frame count, and the joint positions (mm, relative to its
  // hips) of the spheres as they stand now.
  describe() {
    return {
      frame: this.frame,
      playing: this.playing,
      figures: this.figures.map((f) => ({
        label: f.label,
        joints: f.joints.length,
        frames: f.frameCount,
        drawnPositionsMm: f.joints.map((j) => [j.position.x, j.position.y, j.position.z]),
      })),
    };
  }
}
