// The Take view's gap fill in a real browser (Debian's Chromium, headless,
// puppeteer-core) against the real server behind a path prefix
// (server_harness.mjs): the first 20 s of an S5 file loaded as a take, a
// 1.5 s gap of every joint marked on it (5 to 6.5 s: frames 250 to 325 at
// 50 Hz) is filled by the server (POST v1/takes:denoise?keep_observed=true)
// with its default fill and with slerp (gap_fill=slerp). Each reply keeps
// the observed values as they were sent (to the 7 significant digits the
// reply writes) and the root translation in the gap, fills the gap's values
// with finite numbers, and the two fills differ in the gap. The filled take
// is drawn beside the recording: the same pose outside the gap (within
// 0.1 mm), another inside it, where the filled figure's joints and bones
// take the gap's colour (read from the scene's materials) and keep their
// own outside it; the gap is shaded on the strip, over its frames. A gap of
// chosen joints leaves the others as observed. A take of the server's data
// root (the whole S5 file, 60 s, reconstructed with path=) is read whole by
// the page (GET v1/clips/motion), drawn under its reconstruction, and a gap
// marked on it is filled alike: every observed value of the file comes back,
// the gap's values are filled. A take that comes with values missing (NaN,
// from the data root or a file) is filled as it loads, drawn filled with its
// own gaps shaded and coloured, and a gap can be marked on it then.
//
//   node take_gap_page_test.mjs NODE_MODULES   (ctest: web_take_view_fills_a_gap_in_chromium)
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { largestDistanceMm } from './fk_reference.mjs';
import { consoleErrorsOf, h36mDatasetDir, launchBrowser, startServer } from './server_harness.mjs';

const TOLERANCE_MM = 0.1;
const RATE = 50;
const TAKE_FRAMES = 20 * RATE;
const GAP = { fromSeconds: 5, toSeconds: 6.5, first: 250, last: 325 };
const nodeModules = process.argv[2];
const puppeteer = createRequire(pathToFileURL(`${nodeModules}/`))('puppeteer-core');
const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'mm-web-take-gap-'));

function step(text) {
  console.log(`-- ${text}`);
}

// Whether the reply's `value` is the `sent` one as the reply writes numbers
// (7 significant digits: -1.0194449 comes back as -1.019445).
function sameAsSent(sent, value) {
  return Math.abs(sent - value) <= 1e-6 * Math.max(Math.abs(sent), 1e-6);
}

// A take with markers lost already: the first 20 s of S5 walking_1 with its
// values `nan` in LOST's spans (joints 6 to 8, the left leg, for 1 s; every
// joint for 0.5 s), as text.
const LOST = [{ first: 300, last: 349, columns: [21, 30] }, { first: 600, last: 624, columns: [3, 99] }];
const lostAt = (f, c) => LOST.some((span) => f >= span.first && f <= span.last && c >= span.columns[0] && c < span.columns[1]);
function lostTakeRows() {
  return fs.readFileSync(path.join(h36mDatasetDir(), 'S5', 'walking_1.txt'), 'utf8').trim().split('\n').slice(0, TAKE_FRAMES)
    .map((row, f) => row.split(',').map((value, c) => (lostAt(f, c) ? 'nan' : value)).join(','));
}

const server = await startServer();
fs.writeFileSync(path.join(server.scratch, 'data', 'small', 'S5', 'walking_1_lost.txt'), `${lostTakeRows().join('\n')}\n`);
const browser = await launchBrowser(puppeteer);
try {
  const page = await browser.newPage();
  const consoleErrors = consoleErrorsOf(page);
  const describe = () => page.evaluate(() => window.motionManifoldPage.view.describe());
  const banner = () => page.$eval('#error', (e) => (e.hidden ? '' : e.textContent));
  const seek = (frame) => page.$eval('#frame', (input, v) => {
    input.value = String(v);
    input.dispatchEvent(new Event('input'));
  }, frame);
  const setField = (selector, value) => page.$eval(selector, (e, v) => {
    e.value = String(v);
    e.dispatchEvent(new Event('input'));
  }, value);

  step(`load ${server.pageUrl}`);
  await page.goto(server.pageUrl, { waitUntil: 'load' });
  await page.waitForSelector('body[data-loaded=true]', { timeout: 60000 });
  assert.equal(await page.$eval('#gap-button', (e) => e.disabled), true, 'no take to mark a gap on yet');

  step(`the first ${TAKE_FRAMES} frames of S5 walking_1 (20 s at ${RATE} Hz) as a take`);
  const rows = fs.readFileSync(path.join(h36mDatasetDir(), 'S5', 'walking_1.txt'), 'utf8').trim().split('\n')
    .slice(0, TAKE_FRAMES);
  const input = rows.map((row) => row.split(',').map(Number));
  const columns = input[0].length;
  const takeFile = path.join(scratch, 'walking_1_20s.txt');
  fs.writeFileSync(takeFile, `${rows.join('\n')}\n`);
  await (await page.$('#take-file')).uploadFile(takeFile);
  await page.$eval('#take-rate', (e, v) => (e.value = String(v)), RATE);
  await page.click('#take-button');
  await page.waitForFunction(() => !document.getElementById('error').hidden ||
                                   !document.getElementById('gap-button').disabled, { timeout: 300000 });
  assert.equal(await banner(), '', 'reconstructing the take, the page shows an error');

  step(`mark ${GAP.fromSeconds} to ${GAP.toSeconds} s of every joint`);
  await setField('#gap-from', GAP.fromSeconds);
  await setField('#gap-to', GAP.toSeconds);
  assert.equal(await page.$eval('#gap-every-joint', (e) => e.checked), true, 'every joint by default');
  const framesText = await page.$eval('#gap-frames', (e) => e.textContent);
  console.log(`   ${framesText}`);
  assert.match(framesText, new RegExp(`^frames ${GAP.first} to ${GAP.last} of ${TAKE_FRAMES} `));
  assert.equal(await page.$$eval('#gap-joints option', (options) => options.length), 32, "the model's 32 joints listed");

  // Fills the gap marked with `method` and returns the page's reply.
  const fill = async (method) => {
    await page.select('#gap-method', method);
    const before = (await page.evaluate(() => window.motionManifoldPage.take.filled())).count;
    await page.click('#gap-button');
    await page.waitForFunction((n) => !document.getElementById('error').hidden ||
                                      window.motionManifoldPage.take.filled().count > n, { timeout: 300000 }, before);
    assert.equal(await banner(), '', `filling the gap with ${method}, the page shows an error`);
    return (await page.evaluate(() => window.motionManifoldPage.take.filled())).reply;
  };
  const inGap = (f) => f >= GAP.first && f <= GAP.last;
  // The reply keeps every observed value and the gap's root translation,
  // and fills the gap's joint values with finite numbers.
  const checkKeepsObserved = (reply, method, sent = input) => {
    assert.equal(reply.frames, sent.length, `${method}: frames`);
    assert.equal(reply.columns, columns, `${method}: columns`);
    let changed = 0;
    for (let f = 0; f < sent.length; ++f) {
      for (let c = 0; c < columns; ++c) {
        const value = reply.values[f * columns + c];
        if (inGap(f) && c >= 3) {
          assert.ok(Number.isFinite(value), `${method}: frame ${f} column ${c} is ${value}`);
          if (!sameAsSent(sent[f][c], value)) ++changed;
        } else {
          assert.ok(sameAsSent(sent[f][c], value), `${method}: observed frame ${f} column ${c} sent ${sent[f][c]}, came back ${value}`);
        }
      }
    }
    console.log(`   ${method}: observed values kept; ${changed} of the gap's ${(GAP.last - GAP.first + 1) * (columns - 3)} values ` +
                'differ from the recording');
    assert.ok(changed > 0, `${method}: the gap came back as the recording, which the server was never sent`);
  };
  // The filled figure beside the recording: the same pose and its own
  // colour outside the gap, the gap's colour inside it.
  const checkDrawn = async (method) => {
    const take = await page.evaluate(() => window.motionManifoldPage.take.describe());
    assert.deepEqual([take.gap.first, take.gap.last, take.gap.method], [GAP.first, GAP.last, method], `${method}: the gap shown`);
    const outside = GAP.first - 50, inside = Math.round((GAP.first + GAP.last) / 2);
    await seek(outside);
    const before = await describe();
    assert.equal(before.frame, outside);
    assert.equal(before.figures.length, 2, `${method}: the recording beside the fill`);
    const [recording, filled] = before.figures;
    assert.equal(recording.label, 'walking_1_20s.txt');
    assert.match(filled.label, new RegExp(`^${method} fill \\(\\d+\\.\\d mm from the recording in the gap\\)$`));
    const gapColour = filled.marked?.colour;
    assert.ok(gapColour, `${method}: the filled figure marks the gap`);
    assert.deepEqual([filled.marked.first, filled.marked.last], [GAP.first, GAP.last]);
    const outsideDistance = largestDistanceMm(filled.drawnPositionsMm, recording.drawnPositionsMm);
    assert.ok(outsideDistance < TOLERANCE_MM, `${method}: frame ${outside}, outside the gap, is drawn ${outsideDistance} mm from the recording`);
    await seek(inside);
    const during = await describe();
    const insideDistance = largestDistanceMm(during.figures[1].drawnPositionsMm, during.figures[0].drawnPositionsMm);
    console.log(`   ${method} drawn: ${filled.jointColour} at frame ${outside}, ${during.figures[1].jointColour} at frame ` +
                `${inside} (gap ${gapColour}); ${outsideDistance.toExponential(2)} mm and ${insideDistance.toFixed(1)} mm ` +
                'from the recording');
    assert.ok(insideDistance > 1, `${method}: frame ${inside}, inside the gap, is drawn as the recording (${insideDistance} mm)`);
    for (const part of ['jointColour', 'boneColour']) {
      assert.notEqual(filled[part], gapColour, `${method}: ${part} outside the gap`);
      assert.equal(during.figures[1][part], gapColour, `${method}: ${part} inside the gap`);
      assert.equal(during.figures[0][part], recording[part], `${method}: the recording's ${part} keeps its colour`);
    }
    // The strip's shading spans the gap's frames (CSS keeps its percentages to a few digits).
    const shade = await page.$eval('#take-strip .gap', (e) => ({ left: parseFloat(e.style.left), width: parseFloat(e.style.width) }));
    assert.ok(Math.abs(shade.left - (100 * GAP.first) / (TAKE_FRAMES - 1)) < 0.01, `${method}: the shading starts at ${shade.left}%`);
    assert.ok(Math.abs(shade.left + shade.width - (100 * GAP.last) / (TAKE_FRAMES - 1)) < 0.01,
              `${method}: the shading ends at ${shade.left + shade.width}%`);
  };

  step('fill it with the service\'s default');
  const byDefault = await fill('borrowed');
  checkKeepsObserved(byDefault, 'borrowed');
  await checkDrawn('borrowed');
  // The window fitted for the gap (the borrowed fill's fallback, fitted
  // whether or not the take's own stretch answers it), as the reply's
  // summary counts it: the one gap, in one window fitted to it.
  const infoText = () => page.$eval('#take-info', (e) => e.textContent);
  assert.match(await infoText(), /filled by borrowed \(1 gap fitted in 1 window\)/, 'the fitted window\'s counts shown');

  step('fill it with slerp');
  const bySlerp = await fill('slerp');
  checkKeepsObserved(bySlerp, 'slerp');
  await checkDrawn('slerp');
  assert.match(await infoText(), /filled by slerp, /, 'slerp fits nothing and says so by saying nothing of fits');
  let largest = 0;
  for (let f = GAP.first; f <= GAP.last; ++f) {
    for (let c = 3; c < columns; ++c) {
      largest = Math.max(largest, Math.abs(byDefault.values[f * columns + c] - bySlerp.values[f * columns + c]));
    }
  }
  console.log(`   the two fills differ in the gap by up to ${largest.toFixed(4)} rad`);
  assert.ok(largest > 1e-3, `the default and slerp fills differ in the gap by ${largest} at most`);

  step('a gap of chosen joints: the others come back as observed');
  await page.$eval('#gap-every-joint', (e) => {
    e.checked = false;
    e.dispatchEvent(new Event('input'));
  });
  // Joints 6 to 8 of H3.6M (the left leg), chosen in the list.
  await page.$$eval('#gap-joints option', (options) => options.forEach((o, j) => (o.selected = j >= 6 && j <= 8)));
  const chosen = await fill('slerp');
  const missing = new Set([6, 7, 8].flatMap((j) => [3 + 3 * j, 4 + 3 * j, 5 + 3 * j]));
  let filledValues = 0;
  for (let f = 0; f < TAKE_FRAMES; ++f) {
    for (let c = 0; c < columns; ++c) {
      const value = chosen.values[f * columns + c];
      if (inGap(f) && missing.has(c)) {
        assert.ok(Number.isFinite(value), `chosen joints: frame ${f} column ${c} is ${value}`);
        if (!sameAsSent(input[f][c], value)) ++filledValues;
      } else {
        assert.ok(sameAsSent(input[f][c], value), `chosen joints: frame ${f} column ${c} sent ${input[f][c]}, came back ${value}`);
      }
    }
  }
  assert.ok(filledValues > 0, 'the chosen joints came back as the recording');
  const take = await page.evaluate(() => window.motionManifoldPage.take.describe());
  assert.equal(take.gap.joints, (await page.$$eval('#gap-joints option', (o) => o.slice(6, 9).map((e) => e.textContent))).join(', '));
  console.log(`   ${take.gap.joints}: ${filledValues} values filled, every other value as observed`);

  const clip = 'small/S5/walking_1.txt';
  step(`a take of the server's data root (${clip}, read there with path=): read whole, a gap of every joint filled`);
  const fileRows = fs.readFileSync(path.join(h36mDatasetDir(), 'S5', 'walking_1.txt'), 'utf8').trim().split('\n')
    .map((row) => row.split(',').map(Number));
  await page.$eval('#gap-every-joint', (e) => {
    e.checked = true;
    e.dispatchEvent(new Event('input'));
  });
  await page.select('#clip-path', clip);
  await page.click('#take-clip-button');
  await page.waitForFunction((n) => !document.getElementById('error').hidden ||
                                    document.getElementById('take-info').textContent.startsWith(`${n}:`),
                             { timeout: 300000 }, clip);
  assert.equal(await banner(), '', 'reconstructing the data-root take, the page shows an error');
  // The take is loaded for the gap form once its whole motion has come.
  await page.waitForFunction((n) => document.getElementById('gap-frames').textContent.includes(` of ${n} `),
                             { timeout: 20000 }, fileRows.length).catch(() => {});
  assert.match(await page.$eval('#gap-frames', (e) => e.textContent), new RegExp(`^frames ${GAP.first} to ${GAP.last} of ${fileRows.length} `));
  const drawn = await describe();
  assert.deepEqual(drawn.figures.map((f) => [f.label, f.frames]).slice(0, 1), [[clip, fileRows.length]],
                   'the data-root file drawn under its reconstruction');
  assert.equal(drawn.figures.length, 2);
  const fromRoot = await fill('slerp');
  checkKeepsObserved(fromRoot, `slerp on ${clip}`, fileRows);
  assert.equal((await page.evaluate(() => window.motionManifoldPage.take.describe())).gap.first, GAP.first);
  assert.equal((await describe()).figures[0].label, clip, 'the fill beside the data-root recording');

  // A take that comes with values missing is filled as it loads, by the
  // form's method, and drawn filled, its own gaps shaded and coloured; the
  // same from the data root (read whole, its NaN spelt "NaN") and from a file.
  const lostRows = lostTakeRows().map((row) => row.split(',').map(Number));
  const checkOwnGapsFilled = async (name, load) => {
    await page.select('#gap-method', 'slerp');
    const before = (await page.evaluate(() => window.motionManifoldPage.take.filled())).count;
    await load();
    await page.waitForFunction((n) => !document.getElementById('error').hidden ||
                                      window.motionManifoldPage.take.filled().count > n, { timeout: 300000 }, before);
    assert.equal(await banner(), '', `loading ${name}, the page shows an error`);
    const reply = (await page.evaluate(() => window.motionManifoldPage.take.filled())).reply;
    assert.equal(reply.frames, TAKE_FRAMES, `${name}: frames`);
    let filledValues = 0;
    for (let f = 0; f < TAKE_FRAMES; ++f) {
      for (let c = 0; c < columns; ++c) {
        const value = reply.values[f * columns + c];
        if (lostAt(f, c)) {
          assert.ok(Number.isFinite(value), `${name}: lost frame ${f} column ${c} came back ${value}`);
          ++filledValues;
        } else {
          assert.ok(sameAsSent(lostRows[f][c], value), `${name}: frame ${f} column ${c} sent ${lostRows[f][c]}, came back ${value}`);
        }
      }
    }
    const take = await page.evaluate(() => window.motionManifoldPage.take.describe());
    assert.equal(take.gap.own, true, `${name}: its own gaps shown`);
    assert.deepEqual(take.gap.spans, LOST.map(({ first, last }) => ({ first, last })), `${name}: the spans shown`);
    assert.equal(take.gap.method, 'slerp');
    assert.equal(await page.$$eval('#take-strip .gap', (shades) => shades.length), LOST.length, `${name}: a shade a gap`);
    await seek(LOST[0].first - 20);
    const outside = await describe();
    assert.equal(outside.figures.length, 1, `${name}: the filled take alone (nothing recorded to compare in its gaps)`);
    assert.match(outside.figures[0].label, /its missing values filled by slerp$/);
    const { colour } = outside.figures[0].marked;
    assert.deepEqual(outside.figures[0].marked.spans, take.gap.spans);
    assert.notEqual(outside.figures[0].jointColour, colour, `${name}: a frame before its gaps in the gap colour`);
    for (const span of LOST) {
      await seek(Math.round((span.first + span.last) / 2));
      assert.equal((await describe()).figures[0].jointColour, colour, `${name}: frames ${span.first} to ${span.last} in the gap colour`);
    }
    // Between the two gaps nothing was filled.
    await seek(Math.round((LOST[0].last + LOST[1].first) / 2));
    assert.notEqual((await describe()).figures[0].jointColour, colour, `${name}: a frame between its gaps in the gap colour`);
    assert.match(await page.$eval('#take-info', (e) => e.textContent), /2 gaps with values missing \(.*\) filled by slerp/);
    console.log(`   ${name}: ${filledValues} missing values filled by slerp, every other value as in the file; 2 gaps shaded`);
  };
  const lostClip = 'small/S5/walking_1_lost.txt';
  step(`a take of the data root with values missing already (${lostClip}): filled as it loads`);
  await page.$eval('#take-rate', (e, v) => (e.value = String(v)), RATE);
  await page.select('#clip-path', lostClip);
  await checkOwnGapsFilled(lostClip, () => page.click('#take-clip-button'));
  step('the same take as a file: filled as it loads');
  const lostFile = path.join(scratch, 'walking_1_lost.txt');
  fs.writeFileSync(lostFile, `${lostTakeRows().join('\n')}\n`);
  await (await page.$('#take-file')).uploadFile(lostFile);
  await checkOwnGapsFilled('walking_1_lost.txt', () => page.click('#take-button'));
  step('a gap marked on the filled take');
  await setField('#gap-from', GAP.fromSeconds);
  await setField('#gap-to', GAP.toSeconds);
  const onFilled = await fill('slerp');
  assert.equal(onFilled.frames, TAKE_FRAMES);
  assert.equal((await describe()).figures.length, 2, 'the marked gap\'s fill beside the filled take');
  assert.deepEqual(consoleErrors, [], 'console errors');
} catch (error) {
  console.error(server.log().slice(-4000));
  throw error;
} finally {
  await browser.close();
  await server.stop();
  fs.rmSync(scratch, { recursive: true, force: true });
}
