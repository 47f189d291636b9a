// The real server for the web tests: motion-manifold-server on loopback
// ports with a scratch model store (the shipped models, linked), a small
// H3.6M data root for training jobs and the page's clip picker (S1: three
// takes; S5: one; copies, since a link out of the data root is not one of
// its clips, open to the page without the token: --public-clips) and a token,
// behind a path prefix served by a small proxy, as a reverse proxy would
// put it; and a small model of a rig other than H3.6M's, trained by the tool
// on CMU dances. Paths come from the environment ctest sets
// (tests/web/CMakeLists.txt).
import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';

export const TOKEN = 'web-test-token';
export const PREFIX = '/motion-manifold/';

export function environment(name) {
  const value = process.env[name];
  if (!value) throw new Error(`${name} is not set (ctest sets it: run the test through ctest)`);
  return value;
}

export function h36mDatasetDir() {
  const root = environment('MM_DATA_DIR');
  const nested = path.join(root, 'h3.6m', 'dataset');
  const dir = fs.existsSync(nested) ? nested : root;
  if (!fs.existsSync(path.join(dir, 'S5'))) throw new Error(`H3.6M not found under MM_DATA_DIR=${root}: run scripts/extract-h36m.sh`);
  return dir;
}

function smallDataRoot(scratch) {
  const dataset = h36mDatasetDir();
  const files = { S1: ['walking_1.txt', 'walking_2.txt', 'eating_1.txt'], S5: ['walking_1.txt', 'greeting_1.txt'] };
  for (const [subject, names] of Object.entries(files)) {
    fs.mkdirSync(path.join(scratch, 'data', 'small', subject), { recursive: true });
    for (const name of names) fs.copyFileSync(path.join(dataset, subject, name), path.join(scratch, 'data', 'small', subject, name));
  }
  return path.join(scratch, 'data');
}

async function waitForFile(file, child, log, seconds) {
  const deadline = Date.now() + seconds * 1000;
  while (!fs.existsSync(file)) {
    if (child.exitCode !== null) throw new Error(`the server exited before it was ready:\n${fs.readFileSync(log, 'utf8')}`);
    if (Date.now() > deadline) throw new Error(`the server was not ready in ${seconds} s:\n${fs.readFileSync(log, 'utf8')}`);
    await new Promise((resolve) => setTimeout(resolve, 50));
  }
  // The file is written whole by the server, but give a partial read one more try.
  for (;;) {
    try { return JSON.parse(fs.readFileSync(file, 'utf8')); } catch { await new Promise((r) => setTimeout(r, 20)); }
  }
}

// Forwards PREFIX* to the server with the prefix taken off, streaming both
// ways (the job event streams included).
function startPrefixProxy(serverPort) {
  const proxy = http.createServer((request, response) => {
    if (!request.url.startsWith(PREFIX)) {
      response.writeHead(404).end(`only ${PREFIX} is proxied`);
      return;
    }
    const upstream = http.request({ host: '127.0.0.1', port: serverPort, method: request.method,
                                    path: `/${request.url.slice(PREFIX.length)}`, headers: request.headers },
                                  (reply) => {
                                    response.writeHead(reply.statusCode, reply.headers);
                                    reply.pipe(response);
                                  });
    upstream.on('error', (error) => response.destroy(error));
    request.pipe(upstream);
  });
  return new Promise((resolve) => proxy.listen(0, '127.0.0.1', () => resolve(proxy)));
}

// A tiny manifold (hidden 16, 3 iterations) of the CMU dances' 43-joint rig
// (cm, 120 Hz), trained by the motion-manifold tool on three of the dances
// under `scratch`; returns { model: its folder, dances: the BVH folder }.
export function trainDanceModel(scratch) {
  execFileSync('tar', ['xJf', path.join(environment('MM_SHARED_DIR'), 'data', 'cmu-dance-bvh.tar.xz'), '-C', scratch]);
  const all = path.join(scratch, 'cmu-dance-bvh');
  const dances = path.join(scratch, 'dances');
  for (const file of ['indian/04.bvh', 'indian/06.bvh', 'martial/03.bvh']) {
    fs.mkdirSync(path.dirname(path.join(dances, file)), { recursive: true });
    fs.copyFileSync(path.join(all, file), path.join(dances, file));
  }
  const tool = environment('MM_TOOL');
  const prepared = path.join(scratch, 'dances.mmd');
  execFileSync(tool, ['prepare', '--bvh', dances, '--name', 'dances', '--out', prepared]);
  execFileSync(tool, ['train', '--variant', 'DKGM', '--dataset', prepared, '--hidden', '16', '--batch', '2',
                      '--iterations', '3', '--seed', '1', '--out', path.join(scratch, 'dances-run')]);
  return { model: path.join(scratch, 'dances-run', 'model'), dances: all };
}

// The server with the shipped models and `models` ({name: folder}) linked
// into its store, `defaultModel` active.
export async function startServer({ models = {}, defaultModel = 'h36m-dkgm-cpu' } = {}) {
  const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'mm-web-test-'));
  const source = environment('MM_SOURCE_DIR');
  const store = path.join(scratch, 'models');
  fs.mkdirSync(store);
  for (const name of ['h36m-dkgm-h100', 'h36m-dkgm-cpu']) fs.symlinkSync(path.join(source, 'models', name), path.join(store, name));
  for (const [name, folder] of Object.entries(models)) fs.symlinkSync(folder, path.join(store, name));
  const log = path.join(scratch, 'server.log');
  const ready = path.join(scratch, 'ready.json');
  const args = ['--grpc-port', '0', '--rest-port', '0', '--address', '127.0.0.1', '--ready-file', ready,
                '--model-store', store, '--default-model', defaultModel, '--auth-token', TOKEN, '--public-clips',
                '--state-dir', path.join(scratch, 'state'), '--data-root', smallDataRoot(scratch),
                // One LibTorch thread: its OpenMP threads spin, and beside
                // another test's they slow each other several times over.
                '--web-root', path.join(source, 'web'), '--threads', '1', '--training-threads', '1',
                // At the default (idle) priority a job waits for a core that no
                // other test keeps busy: under ctest -j2 the page's one job
                // waited over 500 s.
                '--training-priority', 'normal'];
  const out = fs.openSync(log, 'a');
  const child = spawn(environment('MM_SERVER_BINARY'), args, { stdio: ['ignore', out, out] });
  const { rest_port: port } = await waitForFile(ready, child, log, 120);
  const proxy = await startPrefixProxy(port);
  const direct = `http://127.0.0.1:${port}`;
  return {
    scratch,
    direct,
    pageUrl: `http://127.0.0.1:${proxy.address().port}${PREFIX}`,
    log: () => fs.readFileSync(log, 'utf8'),
    // One REST call straight to the server; returns the parsed reply.
    async call(method, route, body) {
      const response = await fetch(`${direct}/${route}`, { method, body: body && JSON.stringify(body),
                                                          headers: body ? { 'Content-Type': 'application/json' } : {} });
      const text = await response.text();
      if (!response.ok) throw new Error(`${method} ${route}: ${response.status} ${text}`);
      return JSON.parse(text);
    },
    async stop() {
      proxy.closeAllConnections?.();
      proxy.close();
      child.kill('SIGTERM');
      await new Promise((resolve) => (child.exitCode !== null ? resolve() : child.on('exit', resolve)));
      fs.rmSync(scratch, { recursive: true, force: true });
    },
  };
}

// Debian's Chromium, headless, with WebGL on the CPU (no GPU here);
// --no-sandbox because ctest may run as root.
export function launchBrowser(puppeteer) {
  return puppeteer.launch({
    executablePath: environment('MM_CHROMIUM'),
    headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--window-size=1500,1000'],
    defaultViewport: { width: 1500, height: 1000 },
  });
}

// The page's console errors and uncaught exceptions, as they come.
export function consoleErrorsOf(page) {
  const errors = [];
  page.on('console', (message) => message.type() === 'error' && errors.push(message.text()));
  page.on('pageerror', (error) => errors.push(`uncaught: ${error.message}`));
  return errors;
}
