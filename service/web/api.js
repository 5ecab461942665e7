// camlabd's API from the page: every call carries the bearer token (kept in this tab's
// session storage, never in a URL), errors become ApiError with camlabd's code and message,
// and streamed answers (the live view, events) are read chunk by chunk with fetch, so they
// carry the token too (an <img> or EventSource could not).

const TOKEN_KEY = 'camlab.token';
let unauthorizedHandler = () => {};

export const enc = encodeURIComponent;

export function token() { return sessionStorage.getItem(TOKEN_KEY) || ''; }
export function setToken(value) { sessionStorage.setItem(TOKEN_KEY, value); }
export function clearToken() { sessionStorage.removeItem(TOKEN_KEY); }
// Called when camlabd answers 401 (the token was replaced, or never right).
export function onUnauthorized(handler) { unauthorizedHandler = handler; }

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message || `HTTP ${status}`);
    this.status = status;
    this.code = code || '';
  }
}

async function errorOf(response) {
  let error = {};
  try { error = (await response.json()).error || {}; } catch (_) { /* not JSON */ }
  return new ApiError(response.status, error.code, error.message || response.statusText);
}

// The raw response of an authenticated request; throws ApiError for an error status.
export async function request(path, { method = 'GET', body, signal } = {}) {
  const headers = { Authorization: `Bearer ${token()}` };
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  const response = await fetch(path, {
    method, headers, signal, cache: 'no-store',
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  if (response.status === 401) {
    const error = await errorOf(response);
    unauthorizedHandler(error);
    throw error;
  }
  if (!response.ok) throw await errorOf(response);
  return response;
}

// JSON in, JSON out.
export async function api(path, options = {}) {
  return (await request(path, options)).json();
}

// An image (a thumbnail, a plot) as an object URL for an <img>; the caller revokes it.
export async function imageUrl(path, signal) {
  const blob = await (await request(path, { signal })).blob();
  return URL.createObjectURL(blob);
}

// Yields the body of a streamed answer as Uint8Array chunks until it ends or `signal` aborts.
export async function* chunks(path, signal) {
  const response = await request(path, { signal });
  const reader = response.body.getReader();
  try {
    for (;;) {
      const { value, done } = await reader.read();
      if (done) return;
      yield value;
    }
  } finally {
    reader.releaseLock();
  }
}

// Server-sent events over fetch: calls onEvent(type, data) for each event; returns when the
// stream ends (the caller reconnects).
export async function readEvents(path, signal, onEvent) {
  const decoder = new TextDecoder();
  let text = '';
  for await (const chunk of chunks(path, signal)) {
    text += decoder.decode(chunk, { stream: true });
    let end;
    while ((end = text.indexOf('\n\n')) >= 0) {
      const block = text.slice(0, end);
      text = text.slice(end + 2);
      let type = 'message';
      const data = [];
      for (const line of block.split('\n')) {
        if (line.startsWith('event:')) type = line.slice(6).trim();
        else if (line.startsWith('data:')) data.push(line.slice(5).trim());
      }
      if (data.length) onEvent(type, JSON.parse(data.join('\n')));
    }
  }
}

export const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

// Text from camlabd or a device (names, messages) made safe to put in HTML.
export function esc(value) {
  return String(value).replace(/[&<>"']/g, (c) => ({
    '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;',
  })[c]);
}
