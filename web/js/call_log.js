// The call log (every REST call: method, path, status, latency) and the
// error banner, which shows an error exactly as the server wrote it.
const MAX_ENTRIES = 200;

export function logCall({ method, path, status, milliseconds, summary = '', bytes = 0 }) {
  const list = document.getElementById('call-log');
  const entry = document.createElement('li');
  entry.className = typeof status === 'number' && status < 400 ? 'ok' : 'failed';
  const sent = bytes ? ` · sent ${(bytes / 1024).toFixed(1)} KiB` : '';
  entry.textContent = `${method} /${path}  ${status}  ${milliseconds.toFixed(0)} ms${sent}${summary ? `  · ${summary}` : ''}`;
  list.prepend(entry);
  while (list.children.length > MAX_ENTRIES) list.lastChild.remove();
}

export function showError(error) {
  const banner = document.getElementById('error');
  banner.textContent = error instanceof Error ? error.message : String(error);
  banner.hidden = false;
}

export function clearError() {
  document.getElementById('error').hidden = true;
}

// Runs an action of the page: clears the banner, and shows what it throws.
export async function runAction(action) {
  clearError();
  try {
    return await action();
  } catch (error) {
    showError(error);
    return undefined;
  }
}
