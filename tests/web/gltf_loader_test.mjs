// three.js's GLTFLoader, in Debian's Chromium, reads the service's glTF
// replies (Accept: model/gltf-binary and model/gltf+json) of a decoded
// H3.6M motion: every joint and End Site a node, the motion's frames at
// 25 Hz (duration (frames - 1) / 25 s), and every joint where our forward
// kinematics puts it, within 0.1 mm. three poses the scene itself: an
// AnimationMixer playing the loaded clip at each frame's time, then the
// nodes' world matrices. The loader is imported from the page's own origin
// (web/vendor/three), as the page would import it.
//
// The service reads them back too: our glb, and Blender's glb and FBX exports
// of our BVH, POSTed to /v1/encode, give the BVH's code.
//
// FBX is read by the service, not written (format/fbx_animation.h), so
// FBXLoader has nothing of ours to read.
//
//   node gltf_loader_test.mjs NODE_MODULES   (ctest: web_gltf_loader_reads_our_export)
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import { pathToFileURL } from 'node:url';
import { largestDistanceMm, referencePositions, writeMotionText } from './fk_reference.mjs';
import { environment, startServer } from './server_harness.mjs';

const TOLERANCE_MM = 0.1;
const nodeModules = process.argv[2];
const puppeteer = createRequire(pathToFileURL(`${nodeModules}/`))('puppeteer-core');

const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'mm-gltf-loader-'));
const server = await startServer();
const browser = await puppeteer.launch({ executablePath: environment('MM_CHROMIUM'), headless: true, args: ['--no-sandbox'] });
try {
  const { skeleton: h36m } = await server.call('GET', 'v1/models/h36m-dkgm-cpu');
  const { codes } = await server.call('POST', 'v1/sample', { count: 1, seed: 5 });
  const { motions } = await server.call('POST', 'v1/decode', { codes });
  const decodedFile = path.join(scratch, 'decoded.txt');
  writeMotionText(decodedFile, motions[0]);
  const reference = referencePositions(decodedFile);
  // The nodes' names: the joints', an End Site's "<parent>_End" (as the BVH
  // library names them; H3.6M's leaves are End Sites).
  const isParent = new Set(h36m.joints.map((j) => j.parent));
  const names = h36m.joints.map((j, i) => (i > 0 && !isParent.has(i) ? `${h36m.joints[j.parent].name}_End` : j.name));

  const page = await browser.newPage();
  await page.goto(server.pageUrl, { waitUntil: 'load' });
  for (const accept of ['model/gltf-binary', 'model/gltf+json']) {
    const reply = await fetch(`${server.direct}/v1/decode`, {
      method: 'POST', headers: { Accept: accept, 'Content-Type': 'application/json' }, body: JSON.stringify({ codes }) });
    assert.equal(reply.status, 200, `${accept}: ${reply.status}`);
    assert.equal(reply.headers.get('content-type'), accept);
    const bytes = Buffer.from(await reply.arrayBuffer());
    // In the page: parse, then pose at every frame; world positions (mm) of
    // every node the skin names, root-relative as our FK's.
    const loaded = await page.evaluate(async (base64, names) => {
      const THREE = await import('three');
      const { GLTFLoader } = await import('three/addons/loaders/GLTFLoader.js');
      const buffer = Uint8Array.from(atob(base64), (c) => c.charCodeAt(0)).buffer;
      const gltf = await new GLTFLoader().parseAsync(buffer, '');
      const clip = gltf.animations[0];
      const nodes = new Map();
      gltf.scene.traverse((o) => nodes.set(o.name, o));
      const mixer = new THREE.AnimationMixer(gltf.scene);
      // Played once and held: a repeating clip at its duration is its frame 0.
      const action = mixer.clipAction(clip);
      action.setLoop(THREE.LoopOnce);
      action.clampWhenFinished = true;
      action.play();
      const frames = clip.tracks[0].times.length;
      const rate = (frames - 1) / clip.duration;
      const positions = [];
      for (let f = 0; f < frames; ++f) {
        mixer.setTime(f / rate);
        gltf.scene.updateMatrixWorld(true);
        const root = nodes.get(names[0]).getWorldPosition(new THREE.Vector3());
        positions.push(names.map((n) => nodes.get(n).getWorldPosition(new THREE.Vector3()).sub(root).multiplyScalar(1000).toArray()));
      }
      const bones = [];
      gltf.scene.traverse((o) => o.isBone && bones.push(o.name));
      return { bones, frames, duration: clip.duration, trackFrames: clip.tracks.map((t) => t.times.length), positions };
    }, bytes.toString('base64'), names);
    assert.deepEqual([...loaded.bones].sort(), [...names].sort(), `${accept}: the nodes are the joints and End Sites`);
    assert.equal(loaded.frames, motions[0].frames, `${accept}: frames`);
    assert.ok(loaded.trackFrames.every((n) => n === motions[0].frames), `${accept}: every track holds every frame`);
    assert.ok(Math.abs(loaded.duration - (motions[0].frames - 1) / 25) < 1e-4, `${accept}: duration ${loaded.duration} s`);
    let worst = 0;
    for (let f = 0; f < loaded.frames; ++f) worst = Math.max(worst, largestDistanceMm(loaded.positions[f], reference[f]));
    assert.ok(worst < TOLERANCE_MM, `${accept}: a joint lies ${worst} mm from our FK`);
    console.log(`${accept}: ${loaded.bones.length} bones, ${loaded.frames} frames over ${loaded.duration.toFixed(3)} s ` +
                `(25 Hz), largest joint distance from our FK ${worst.toExponential(2)} mm`);
  }

  // And the service reads glTF and FBX bodies: our glb, and Blender's glb and
  // FBX exports of our BVH (Blender's own importer and exporters), encode to
  // the code of the BVH itself.
  const post = async (route, body, contentType, accept = 'application/json') => {
    const reply = await fetch(`${server.direct}/${route}`, { method: 'POST', body, headers: { 'Content-Type': contentType, Accept: accept } });
    const bytes = Buffer.from(await reply.arrayBuffer());
    assert.equal(reply.status, 200, `${route} (${contentType}): ${reply.status} ${bytes.toString().slice(0, 400)}`);
    return bytes;
  };
  const bvh = await post('v1/decode', JSON.stringify({ codes }), 'application/json', 'application/x-bvh');
  const glb = await post('v1/decode', JSON.stringify({ codes }), 'application/json', 'model/gltf-binary');
  const codeOf = async (body, type) => JSON.parse((await post('v1/encode', body, type)).toString()).codes[0];
  const bvhCode = await codeOf(bvh, 'application/x-bvh');
  const bodies = [['our glb', glb, 'model/gltf-binary']];
  const blender = environment('MM_BLENDER');
  if (blender) {
    const bvhFile = path.join(scratch, 'decoded.bvh');
    fs.writeFileSync(bvhFile, bvh);
    const convert = new URL('../format/blender_convert_bvh.py', import.meta.url).pathname;
    for (const extension of ['glb', 'fbx']) {
      const out = path.join(scratch, `blender.${extension}`);
      execFileSync(blender, ['--background', '--factory-startup', '--python-exit-code', '1', '--python', convert, '--',
                             bvhFile, out, '0.001'], { stdio: 'ignore' });
      bodies.push([`Blender's ${extension}`, fs.readFileSync(out), extension === 'glb' ? 'model/gltf-binary' : 'application/octet-stream']);
    }
  }
  for (const [label, body, type] of bodies) {
    const code = await codeOf(body, type);
    const difference = Math.max(...code.map((v, i) => Math.abs(v - bvhCode[i])));
    assert.ok(difference < 1e-2, `${label} (${type}): its code differs from the BVH's by up to ${difference}`);
    console.log(`${label} sent as ${type}: encoded to the BVH's code within ${difference.toExponential(2)}`);
  }
} finally {
  await browser.close();
  await server.stop();
  fs.rmSync(scratch, { recursive: true, force: true });
}
