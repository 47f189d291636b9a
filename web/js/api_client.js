// Every REST call of the page goes through here: relative URLs (so the page
// works behind a path prefix), the bearer token on the calls that change
// state, and one entry in the call log per call (method, path, status,
// latency) so that the page also shows the API it uses.
import { logCall } from './call_log.js';

// An error reply of the server, kept as it came: the status and the body's
// {"error": {code, field, message}} (or the raw text when it is not JSON).
export class ApiError extends Error {
  constructor(method, path, status, bodyText) {
    let message = bodyText;
    try {
      const error = JSON.parse(bodyText).error;
      if (error) message = `${error.code}${error.field ? ` (${error.field})` : ''}: ${error.message}`;
    } catch { /* not JSON: the text itself is the message */ }
    super(`${method} ${path} -> ${status} ${message}`);
    this.status = status;
    this.bodyText = bodyText;
  }
}

export function tokenInput() {
  return document.getElementById('token');
}

// The token field's value, or one asked for now when the field is empty
// (for the calls that need it).
export function tokenOrPrompt() {
  const field = tokenInput();
  if (!field.value) field.value = window.prompt('Bearer token of the server (--auth-token)') ?? '';
  return field.value;
}

// Calls `method path` (path without a leading slash, relative to the page)
// and returns the parsed JSON reply, or the text for another content type.
// `body` is sent as JSON unless `contentType` says otherwise; `accept`
// asks for another reply format (a BVH file, motion text). Throws
// ApiError for an error status and TypeError when the server is unreachable.
export async function callApi(method, path, { body, contentType = 'application/json', accept, token, summary } = {}) {
  const headers = {};
  if (accept) headers.Accept = accept;
  if (body !== undefined) headers['Content-Type'] = contentType;
  if (token) headers.Authorization = `Bearer ${token}`;
  const payload = body === undefined ? undefined : contentType === 'application/json' ? JSON.stringify(body) : body;
  const started = performance.now();
  let response;
  try {
    response = await fetch(path, { method, headers, body: payload });
  } catch (error) {
    logCall({ method, path, status: 'network error', milliseconds: performance.now() - started, summary });
    throw error;
  }
  // A glTF reply is a file to save, never parsed here: the bytes as they came
  // (model/gltf-binary, an ArrayBuffer) or the text (model/gltf+json).
  const type = response.headers.get('Content-Type') ?? '';
  const binary = response.ok && type.startsWith('model/gltf-binary');
  const bytes = binary ? await response.arrayBuffer() : null;
  const text = binary ? '' : await response.text();
  logCall({ method, path, status: response.status, milliseconds: performance.now() - started, summary,
            bytes: payload?.length ?? payload?.size ?? 0 });
  if (!response.ok) throw new ApiError(method, path, response.status, text);
  if (binary) return bytes;
  return type.includes('json') && !type.startsWith('model/') ? JSON.parse(text) : text;
}

// A call that changes state: sent with the token field's value, and once
// more with a token asked for when the server answers 401 UNAUTHENTICATED.
export async function callWithToken(method, path, options = {}) {
  try {
    return await callApi(method, path, { ...options, token: tokenInput().value });
  } catch (error) {
    if (!(error instanceof ApiError) || error.status !== 401) throw error;
    tokenInput().value = '';
    return callApi(method, path, { ...options, token: tokenOrPrompt() });
  }
}
