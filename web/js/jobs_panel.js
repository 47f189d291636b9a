// Training jobs: submit, the list with live progress from each unfinished
// job's Server-Sent Events (GET v1/jobs/{id}/events), its loss curves as
// they come, cancel, and delete (a finished job: its record and its folder
// on the server; the model it published stays).
import { callApi, callWithToken } from './api_client.js';
import { logCall, runAction } from './call_log.js';
import { LossChart } from './loss_chart.js';

const $ = (id) => document.getElementById(id);
const TERMINAL = new Set(['succeeded', 'failed', 'cancelled']);
const streams = new Map();  // job id -> EventSource
const charts = new Map();   // job id -> LossChart

function progressText(job) {
  const p = job.progress ?? {};
  const parts = [`${p.iteration ?? 0} / ${p.total ?? '?'}`];
  if (p.iterations_per_second) parts.push(`${p.iterations_per_second.toFixed(1)} it/s`);
  if (p.eta_seconds && !TERMINAL.has(job.state)) parts.push(`ETA ${Math.round(p.eta_seconds)} s`);
  if (job.error) parts.push(job.error);
  if (job.published_model) parts.push(`published ${job.published_model}`);
  return parts.join(' · ');
}

// The job's row, made on first sight; its cells are updated in place.
function jobRow(job) {
  let row = document.querySelector(`#jobs tr[data-job="${job.id}"]`);
  if (row) return row;
  row = document.createElement('tr');
  row.dataset.job = job.id;
  row.innerHTML = `<td class="id"></td><td class="dataset"></td><td class="state"></td>
    <td><progress max="1" value="0"></progress> <span class="progress"></span></td>
    <td><button class="cancel">Cancel</button> <button class="delete">Delete</button></td>`;
  row.querySelector('.id').textContent = job.id;
  row.querySelector('.dataset').textContent = `${job.spec.dataset} ${job.spec.variant}`;
  row.querySelector('.cancel').addEventListener('click', () => runAction(async () => {
    update(await callWithToken('POST', `v1/jobs/${job.id}:cancel`));
  }));
  row.querySelector('.delete').addEventListener('click', () => runAction(async () => {
    if (!window.confirm(`Delete job ${job.id}? Its record and its folder (log, checkpoint) are removed.`)) return;
    await callWithToken('DELETE', `v1/jobs/${job.id}`);
    forget(job.id);
  }));
  row.addEventListener('click', (event) => {
    if (event.target.tagName !== 'BUTTON') selectChart(job.id);
  });
  $('jobs').append(row);
  $('jobs-status').textContent = `${$('jobs').rows.length} jobs`;
  return row;
}

function selectChart(id) {
  $('loss-chart-title').textContent = `losses of job ${id} (click a row to choose)`;
  $('loss-chart').dataset.job = id;
  charts.get(id)?.draw();
}

function update(job) {
  const row = jobRow(job);
  row.dataset.state = job.state;
  row.querySelector('.state').textContent = job.state;
  const total = job.progress?.total || 0;
  row.querySelector('progress').value = total ? job.progress.iteration / total : 0;
  row.querySelector('.progress').textContent = progressText(job);
  row.querySelector('.cancel').disabled = TERMINAL.has(job.state);
  row.querySelector('.delete').disabled = !TERMINAL.has(job.state);
  if (!charts.has(job.id)) charts.set(job.id, new LossChart($('loss-chart')));
  charts.get(job.id).add(job.progress ?? {});
  // The chart shows the job picked last, or else the first one still running.
  if (!$('loss-chart').dataset.job && !TERMINAL.has(job.state)) selectChart(job.id);
  if ($('loss-chart').dataset.job === job.id) charts.get(job.id).draw();
}

// A deleted job's row, chart and stream.
function forget(id) {
  document.querySelector(`#jobs tr[data-job="${id}"]`)?.remove();
  streams.get(id)?.close();
  streams.delete(id);
  charts.delete(id);
  if ($('loss-chart').dataset.job === id) {
    delete $('loss-chart').dataset.job;
    $('loss-chart').getContext('2d').clearRect(0, 0, $('loss-chart').width, $('loss-chart').height);
    $('loss-chart-title').textContent = 'losses';
  }
  $('jobs-status').textContent = `${$('jobs').rows.length} jobs`;
}

// Follows a job's events until it ends. EventSource reconnects on its own
// after a dropped connection; a finished job's stream is closed here, or it
// would reconnect to a job that has nothing more to say.
function watch(job) {
  if (TERMINAL.has(job.state) || streams.has(job.id)) return;
  const path = `v1/jobs/${job.id}/events`;
  const opened = performance.now();
  const source = new EventSource(path);
  streams.set(job.id, source);
  let first = true;
  source.addEventListener('job', (event) => {
    const record = JSON.parse(event.data);
    if (first) logCall({ method: 'GET', path, status: 200, milliseconds: performance.now() - opened, summary: 'event stream, first event' });
    first = false;
    update(record);
    if (TERMINAL.has(record.state)) {
      source.close();
      streams.delete(job.id);
    }
  });
  source.addEventListener('error', (event) => {
    if (event.data) $('jobs-status').textContent = `event stream of ${job.id}: ${event.data}`;
  });
}

async function refresh() {
  const { jobs } = await callApi('GET', 'v1/jobs');
  jobs.slice().reverse().forEach((job) => {
    update(job);
    watch(job);
  });
}

async function submit() {
  const spec = { dataset: $('job-dataset').value, variant: $('job-variant').value,
                 iterations: Number($('job-iterations').value), hidden: Number($('job-hidden').value) };
  if ($('job-model-name').value) spec.model_name = $('job-model-name').value;
  const job = await callWithToken('POST', 'v1/jobs', { body: spec });
  update(job);
  selectChart(job.id);
  watch(job);
}

export function setUpJobsPanel() {
  $('jobs-refresh').addEventListener('click', () => runAction(refresh));
  $('job-submit').addEventListener('click', () => runAction(submit));
  return runAction(refresh);
}
