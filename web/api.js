// The udvr serve HTTP API (docs/serve.md). Errors come back as {error: "…"} with a 4xx status.
export class ApiError extends Error {
  constructor(status, message) {
    super(message);
    this.status = status;
  }
}

async function check(response) {
  if (response.ok) return response;
  let message = response.statusText;
  try {
    message = (await response.json()).error || message;
  } catch (e) { /* not JSON */ }
  throw new ApiError(response.status, message);
}

export function query(params) {
  return Object.entries(params)
      .filter(([, v]) => v !== undefined && v !== null && v !== '')
      .map(([k, v]) => encodeURIComponent(k) + '=' + encodeURIComponent(v))
      .join('&');
}

export async function getJson(path, params = {}, options = {}) {
  const q = query(params);
  const r = await check(await fetch(path + (q ? '?' + q : ''), options));
  return r.json();
}

export async function getText(path) {
  return (await check(await fetch(path))).text();
}

export async function postJson(path, text) {
  const r = await check(await fetch(path, {
    method: 'POST', body: text, headers: {'Content-Type': 'application/json'}}));
  return r.json();
}

// /api/render's answer as bytes (the PNG, or with format=rgba its 8-bit RGBA values), with the
// response headers.
export async function getRender(params, options = {}) {
  const r = await check(await fetch('/api/render?' + query(params), options));
  return {bytes: await r.arrayBuffer(), headers: r.headers};
}
