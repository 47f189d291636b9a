// A user's own BVH, glTF or FBX files (of one rig, mixed or not) sent to the server's data root (POST
// v1/clips:upload, the file as the body, the token asked for on a 401) into
// one folder, which then becomes the dataset a job trains on: the way to a
// manifold of one's own mocap from the browser. (An H3.6M text tree needs
// its subject folders, which a file input does not give: the client's
// `clips upload` sends those.)
import { callWithToken } from './api_client.js';
import { runAction } from './call_log.js';
import { listClips } from './data_root_clips.js';

const $ = (id) => document.getElementById(id);

async function upload() {
  const files = [...$('dataset-files').files];
  if (!files.length) throw new Error('choose .bvh, .glb, .gltf or .fbx files of one rig first');
  const folder = $('dataset-folder').value.replace(/\/+$/, '');
  if (!folder) throw new Error('name the folder of the data root to put the files in');
  for (const [i, file] of files.entries()) {
    $('dataset-status').textContent = `sending ${i + 1} of ${files.length}: ${file.name}`;
    const path = `${folder}/${file.name}`;
    await callWithToken('POST', `v1/clips:upload?path=${encodeURIComponent(path)}`,
                        { body: file, contentType: 'application/octet-stream', summary: path });
  }
  $('job-dataset').value = folder;
  $('dataset-status').textContent = `${files.length} files in ${folder}: Submit trains on them`;
  await listClips();
}

export function setUpDatasetUpload() {
  $('dataset-upload').addEventListener('click', () => runAction(upload));
}
