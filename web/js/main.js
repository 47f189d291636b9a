// The page's entry: the 3D view, then the panels and the data root's clips,
// each of which talks to the server only through the REST API (api_client.js).
import { SkeletonView } from './skeleton_view.js';
import { setUpManifoldPanel } from './manifold_panel.js';
import { setUpTakePanel } from './take_panel.js';
import { setUpJobsPanel } from './jobs_panel.js';
import { setUpModelsPanel } from './models_panel.js';
import { setUpClipPicker } from './data_root_clips.js';
import { setUpDatasetUpload } from './dataset_upload.js';
import { runAction, showError } from './call_log.js';
import { callApi } from './api_client.js';

const $ = (id) => document.getElementById(id);

try {
  const view = new SkeletonView({ container: $('view'), playButton: $('play'), slider: $('frame'),
                                  frameLabel: $('frame-label'), legend: $('legend'), overlayBox: $('overlay') });
  setUpManifoldPanel(view);
  // Read by the browser test: what the view draws.
  window.motionManifoldPage = { view };
  setUpTakePanel(view);
} catch (error) {
  // No WebGL, say: the jobs and models still work.
  showError(`the 3D view cannot start: ${error.message}`);
}
await runAction(async () => {
  const ready = await callApi('GET', 'readyz');
  $('server-status').textContent = `server ${ready.status}`;
});
setUpDatasetUpload();
await Promise.all([setUpModelsPanel(), setUpJobsPanel(), setUpClipPicker()]);
document.body.dataset.loaded = 'true';
