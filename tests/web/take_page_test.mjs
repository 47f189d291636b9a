// The page's Take view in a real browser (Debian's Chromium, headless,
// puppeteer-core) against the real server behind a path prefix
// (server_harness.mjs): a whole S5 file loaded as a take is reconstructed
// over REST (POST v1/takes:reconstruct) and plays at 50 Hz with every frame
// of the file, its code track drawn as one cell per window, its per-frame
// error plotted for every frame; clicking a cell, clicking the plot and
// moving the slider put both skeletons at that frame, drawn as the model
// library's FK of the file's row and of the server's reconstruction within
// 0.1 mm; the same file read by the server from its data root (path=)
// plays its reconstruction over the file, which the page reads whole from
// there (GET v1/clips/motion). "Download BVH" gets the take shown as a BVH
// file (Accept: application/x-bvh) with the take's frame count and a Frame
// Time of 1/50 s for the S5 file, uploaded or read by the server; a 120 Hz BVH take (the server's decoded
// track) downloads at 120 Hz with its frame count. The screenshot (web-take.png) is of a take the
// server made itself (sampled codes decoded as a track), since H3.6M never
// goes into docs/.
//
//   node take_page_test.mjs NODE_MODULES   (ctest: web_take_view_in_chromium)
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { largestDistanceMm, referencePositions, writeMotionText } from './fk_reference.mjs';
import { consoleErrorsOf, h36mDatasetDir, launchBrowser, startServer } from './server_harness.mjs';

const TOLERANCE_MM = 0.1;
const nodeModules = process.argv[2];
const puppeteer = createRequire(pathToFileURL(`${nodeModules}/`))('puppeteer-core');
const screenshotDir = process.env.MM_WEB_SCREENSHOT_DIR || path.join(nodeModules, '..', 'screenshots');
fs.mkdirSync(screenshotDir, { recursive: true });
const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'mm-web-take-'));

function step(text) {
  console.log(`-- ${text}`);
}

const server = await startServer();
const browser = await launchBrowser(puppeteer);
try {
  const page = await browser.newPage();
  const consoleErrors = consoleErrorsOf(page);
  const describe = () => page.evaluate(() => window.motionManifoldPage.view.describe());
  const describeTake = () => page.evaluate(() => window.motionManifoldPage.take.describe());
  const setRange = (selector, value) => page.$eval(selector, (input, v) => {
    input.value = String(v);
    input.dispatchEvent(new Event('input'));
  }, value);
  // Waits for the take view to show `frames` frames, failing with the
  // page's error banner when that shows instead.
  const waitForTake = async (name) => {
    await page.waitForFunction((n) => !document.getElementById('error').hidden ||
                                      document.getElementById('take-info').textContent.startsWith(`${n}:`),
                               { timeout: 300000 }, name);
    const banner = await page.$eval('#error', (e) => (e.hidden ? '' : e.textContent));
    assert.equal(banner, '', `waiting for the take ${name}, the page shows an error`);
  };
  // The BVH header's frame count and frame time.
  const bvhTiming = (text) => ({ frames: Number(/^Frames:\s*(\d+)/m.exec(text)?.[1]),
                                 frameTime: Number(/^Frame Time:\s*(\S+)/m.exec(text)?.[1]) });
  // Clicks "Download BVH" and returns what the page downloaded.
  const downloadBvh = async () => {
    const before = (await page.evaluate(() => window.motionManifoldPage.take.downloaded())).count;
    await page.click('#take-download-button');
    await page.waitForFunction((n) => !document.getElementById('error').hidden ||
                                      window.motionManifoldPage.take.downloaded().count > n, { timeout: 300000 }, before);
    const banner = await page.$eval('#error', (e) => (e.hidden ? '' : e.textContent));
    assert.equal(banner, '', 'downloading the take as BVH, the page shows an error');
    return page.evaluate(() => window.motionManifoldPage.take.downloaded());
  };
  const reconstructFile = async (file, rate) => {
    await (await page.$('#take-file')).uploadFile(file);
    await page.$eval('#take-rate', (e, v) => (e.value = String(v)), rate);
    await page.click('#take-button');
    await waitForTake(path.basename(file));
  };

  step(`load ${server.pageUrl}`);
  await page.goto(server.pageUrl, { waitUntil: 'load' });
  await page.waitForSelector('body[data-loaded=true]', { timeout: 60000 });
  assert.deepEqual(consoleErrors, [], 'console errors while loading');
  assert.equal(await page.$eval('#take-download-button', (e) => e.disabled), true, 'no take to download yet');

  step('a whole S5 file as a take: every frame plays at 50 Hz beside its reconstruction');
  const s5File = path.join(h36mDatasetDir(), 'S5', 'greeting_1.txt');
  const rows = fs.readFileSync(s5File, 'utf8').trim().split('\n');
  // The server's own reply to the same take, for the windows and the reconstruction.
  const direct = await fetch(`${server.direct}/v1/takes:reconstruct?frame_rate=50`, {
    method: 'POST', headers: { 'Content-Type': 'text/plain' }, body: fs.readFileSync(s5File) });
  assert.equal(direct.status, 200, await direct.clone().text());
  const reply = await direct.json();
  assert.equal(reply.frames, rows.length);
  await reconstructFile(s5File, 50);
  let view = await describe();
  assert.equal(view.figures.length, 2);
  assert.equal(view.figures[0].label, 'greeting_1.txt');
  assert.match(view.figures[1].label, /^reconstruction \(\d+\.\d mm\)$/);
  for (const figure of view.figures) {
    assert.equal(figure.joints, 32);
    assert.equal(figure.frames, rows.length, 'frames played');
  }
  assert.equal(view.playing, true);
  assert.match(await page.$eval('#frame-label', (e) => e.textContent), new RegExp(`/ ${rows.length} at 50 Hz`));
  await page.waitForFunction((before) => window.motionManifoldPage.view.describe().frame !== before,
                             { timeout: 10000 }, view.frame);
  const take = await describeTake();
  console.log(`   ${JSON.stringify(take)}`);
  assert.equal(take.frames, rows.length);
  assert.equal(take.frameRate, 50);
  assert.equal(take.windows, reply.windows.length);
  assert.equal(take.cells, reply.windows.length, 'one strip cell per window');
  assert.equal(take.errorFrames, rows.length);
  assert.equal(Number(await page.$eval('#take-error', (e) => e.dataset.frames)), rows.length, 'the error plot has every frame');

  step('Download BVH: the take shown as a BVH file of every frame at 50 Hz');
  let download = await downloadBvh();
  assert.equal(download.fileName, 'greeting_1-reconstructed.bvh');
  let timing = bvhTiming(download.bvh);
  console.log(`   ${download.fileName}: ${download.bvh.length} bytes, ${JSON.stringify(timing)}`);
  assert.equal(timing.frames, rows.length, 'Frames: of the downloaded BVH');
  assert.ok(Math.abs(timing.frameTime - 1 / 50) < 1e-6, `Frame Time ${timing.frameTime}, expected 1/50 s`);

  step('Download glb: the take shown as a glTF binary (web_gltf_loader_reads_our_export reads such a reply)');
  const beforeGlb = (await page.evaluate(() => window.motionManifoldPage.take.downloaded())).count;
  await page.click('#take-download-glb-button');
  await page.waitForFunction((n) => window.motionManifoldPage.take.downloaded().count > n, { timeout: 300000 }, beforeGlb);
  const glb = await page.evaluate(() => window.motionManifoldPage.take.downloaded());
  assert.equal(glb.fileName, 'greeting_1-reconstructed.glb');
  // 25 rotations and a translation of 4-byte floats a frame, at least.
  assert.ok(glb.bytes > rows.length * (25 * 16 + 12), `the glb holds ${glb.bytes} bytes for ${rows.length} frames`);
  console.log(`   ${glb.fileName}: ${glb.bytes} bytes`);

  step('scrubbing moves both skeletons to the frame: the FK of the file and of the reconstruction');
  const originalReference = referencePositions(s5File);
  const reconstructionFile = path.join(scratch, 'reconstruction.txt');
  writeMotionText(reconstructionFile, reply);
  const reconstructionReference = referencePositions(reconstructionFile);
  const checkBothAt = async (frame, how) => {
    view = await describe();
    assert.equal(view.frame, frame, how);
    assert.equal(view.playing, false, `${how}: seeking pauses`);
    const original = largestDistanceMm(view.figures[0].drawnPositionsMm, originalReference[frame]);
    const reconstructed = largestDistanceMm(view.figures[1].drawnPositionsMm, reconstructionReference[frame]);
    console.log(`   ${how}, frame ${frame}: largest distances ${original.toExponential(2)} mm (original), ` +
                `${reconstructed.toExponential(2)} mm (reconstruction)`);
    assert.ok(original < TOLERANCE_MM, `${how}: the original lies ${original} mm from the FK at frame ${frame}`);
    assert.ok(reconstructed < TOLERANCE_MM, `${how}: the reconstruction lies ${reconstructed} mm from the FK at frame ${frame}`);
  };
  const cell = Math.floor(reply.windows.length / 2);
  await page.click(`#take-strip .cell:nth-child(${cell + 1})`);
  await checkBothAt(reply.windows[cell].start_frame, `strip cell ${cell + 1}`);
  // The plot's x runs over the frames after a 38 px margin (take_panel.js).
  const plot = await page.$eval('#take-error', (e) => ({ width: e.width, clientWidth: e.clientWidth }));
  const clickX = 38 + 0.25 * (plot.width - 38);
  await page.click('#take-error', { offset: { x: (clickX * plot.clientWidth) / plot.width, y: 40 } });
  view = await describe();
  const plotFrame = view.frame;
  assert.ok(Math.abs(plotFrame - 0.25 * (rows.length - 1)) <= (rows.length / plot.width) * 2,
            `a click at a quarter of the plot shows frame ${plotFrame} of ${rows.length}`);
  await checkBothAt(plotFrame, 'error plot');
  await setRange('#frame', rows.length - 1);
  await checkBothAt(rows.length - 1, 'slider');

  step("the same file read by the server from its data root (path=)");
  await page.select('#clip-path', 'small/S5/greeting_1.txt');
  await page.click('#take-clip-button');
  await waitForTake('small/S5/greeting_1.txt');
  view = await describe();
  // The file, read whole from the data root (GET v1/clips/motion), under its reconstruction.
  assert.deepEqual(view.figures.map((f) => [f.label, f.frames]).slice(0, 1), [['small/S5/greeting_1.txt', rows.length]]);
  assert.equal(view.figures.length, 2);
  assert.equal(view.figures[1].frames, rows.length);
  assert.equal((await describeTake()).cells, reply.windows.length);
  download = await downloadBvh();
  assert.equal(download.fileName, 'greeting_1-reconstructed.bvh', 'a data-root file is named without its folders');
  assert.deepEqual(bvhTiming(download.bvh), { frames: rows.length, frameTime: 0.02 }, 'the data-root file as BVH');

  step('a take of the model\'s own for the screenshot: sampled codes decoded as a track, 50 Hz');
  const { codes } = await server.call('POST', 'v1/sample', { count: 6, seed: 11 });
  const track = await server.call('POST', 'v1/tracks:decode', {
    windows: codes.map((code, i) => ({ start_seconds: 3 * i, code })), frame_rate: 50 });
  const ownFile = path.join(scratch, 'sampled_track.txt');
  writeMotionText(ownFile, track);
  await reconstructFile(ownFile, 50);
  assert.equal((await describe()).figures[0].frames, track.frames);
  await page.click('#play');
  await setRange('#frame', Math.floor(track.frames * 0.4));
  await page.screenshot({ path: path.join(screenshotDir, 'web-take.png') });

  step('a 120 Hz BVH take (the same codes decoded at 120 Hz) downloads as a 120 Hz BVH of every frame');
  const bvhReply = await fetch(`${server.direct}/v1/tracks:decode`, {
    method: 'POST', headers: { 'Content-Type': 'application/json', Accept: 'application/x-bvh' },
    body: JSON.stringify({ windows: codes.map((code, i) => ({ start_seconds: 3 * i, code })), frame_rate: 120 }) });
  const bvh120 = await bvhReply.text();
  assert.equal(bvhReply.status, 200, bvh120);
  const input120 = bvhTiming(bvh120);
  assert.ok(Math.abs(input120.frameTime - 1 / 120) < 1e-6, `the decoded track's Frame Time ${input120.frameTime}`);
  const file120 = path.join(scratch, 'sampled_track_120.bvh');
  fs.writeFileSync(file120, bvh120);
  await reconstructFile(file120, 50);
  const take120 = await describeTake();
  assert.equal(take120.frameRate, 120);
  assert.equal(take120.frames, input120.frames);
  download = await downloadBvh();
  assert.equal(download.fileName, 'sampled_track_120-reconstructed.bvh');
  timing = bvhTiming(download.bvh);
  console.log(`   ${download.fileName}: ${input120.frames} frames in, ${JSON.stringify(timing)} out`);
  assert.equal(timing.frames, input120.frames, 'Frames: of the downloaded BVH');
  assert.ok(Math.abs(timing.frameTime - 1 / 120) < 1e-6, `Frame Time ${timing.frameTime}, expected 1/120 s`);
  assert.deepEqual(consoleErrors, [], 'console errors');
} catch (error) {
  console.error(server.log().slice(-4000));
  throw error;
} finally {
  await browser.close();
  await server.stop();
  fs.rmSync(scratch, { recursive: true, force: true });
}
