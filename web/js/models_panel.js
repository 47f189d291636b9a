// The model store: every model with its Table 1 evaluation (mean per-joint
// position error in mm over the clip's intervals, per decoder), an activate
// and a delete button (the server refuses the active and the default model),
// which ask for the token when the server wants one.
import { callApi, callWithToken } from './api_client.js';
import { runAction } from './call_log.js';

const $ = (id) => document.getElementById(id);

// Table 1 in mm: one row per decoder, one column per interval of the clip.
function evaluationTable(evaluation) {
  const table = document.createElement('table');
  table.className = 'evaluation';
  const decoders = Object.entries(evaluation.decoders ?? {});
  if (!decoders.length) {
    table.innerHTML = '<tr><td>no evaluation</td></tr>';
    return table;
  }
  const interval = evaluation.interval_seconds ?? 0;
  const columns = decoders[0][1].mpjpe_mm.length;
  const header = Array.from({ length: columns }, (_, i) => `<th>${(i * interval).toFixed(1)}–${((i + 1) * interval).toFixed(1)} s</th>`);
  table.innerHTML = `<tr><th>MPJPE mm</th>${header.join('')}<th>E_z</th></tr>`;
  for (const [name, numbers] of decoders) {
    const row = table.insertRow();
    row.insertCell().textContent = name;
    numbers.mpjpe_mm.forEach((v) => (row.insertCell().textContent = v.toFixed(1)));
    row.insertCell().textContent = numbers.E_z?.toFixed(3) ?? '';
  }
  return table;
}

async function describe(name, cell) {
  const info = await callApi('GET', `v1/models/${encodeURIComponent(name)}`);
  cell.replaceChildren(evaluationTable(info.evaluation ?? {}));
}

async function refresh() {
  const { models } = await callApi('GET', 'v1/models');
  const list = $('models');
  list.replaceChildren();
  for (const model of models) {
    const row = list.insertRow();
    row.dataset.model = model.name;
    const nameCell = row.insertCell();
    nameCell.textContent = `${model.name}: ${model.variant}, hidden ${model.hidden}, latent ${model.latent}, version ${model.version} `;
    const evaluationCell = row.insertCell();
    const button = document.createElement('button');
    button.textContent = model.active ? 'Active' : 'Activate';
    button.disabled = model.active;
    button.addEventListener('click', () => runAction(async () => {
      await callWithToken('POST', `v1/models/${encodeURIComponent(model.name)}:activate`);
      await refresh();
    }));
    const remove = document.createElement('button');
    remove.className = 'delete';
    remove.textContent = 'Delete';
    remove.disabled = model.active;
    remove.addEventListener('click', () => runAction(async () => {
      if (!window.confirm(`Delete model ${model.name}? Its folder is removed from the server's store.`)) return;
      await callWithToken('DELETE', `v1/models/${encodeURIComponent(model.name)}`);
      await refresh();
    }));
    nameCell.append(button, ' ', remove);
    await describe(model.name, evaluationCell);
  }
}

export function setUpModelsPanel() {
  $('models-refresh').addEventListener('click', () => runAction(refresh));
  return runAction(refresh);
}
