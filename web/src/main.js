// The operator's web view (docs/web.md): log-in, then the pages by URL hash.
import * as api from './api.js';
import { mountLogin } from './pages/login.js';
import { mountLive } from './pages/live.js';
import { mountDevices } from './pages/devices.js';
import { mountSessions } from './pages/sessions.js';
import { mountResults } from './pages/results.js';
import { startSessionBar } from './session_bar.js';
import { startTheme } from './theme.js';

const PAGES = {
  live: { title: 'Live', mount: mountLive },
  devices: { title: 'Devices and calibration', mount: mountDevices },
  sessions: { title: 'Sessions', mount: mountSessions },
  results: { title: 'Results', mount: mountResults },
};

const main = document.getElementById('main');
const nav = document.getElementById('nav');
const banner = document.getElementById('connection');
let unmountCurrent = null;
let loggedIn = false;
let stopSessionBar = null;  // the running operation's bar, on every page once logged in

function show(mount, argument) {
  if (unmountCurrent) unmountCurrent();
  main.replaceChildren();
  unmountCurrent = mount(main, argument) ?? null;
}

function route() {
  if (!loggedIn) {
    if (stopSessionBar) stopSessionBar();
    stopSessionBar = null;
    nav.hidden = true;
    document.title = 'Log in · Chromosphere';
    show(mountLogin, async () => {
      loggedIn = true;
      if (!location.hash || location.hash === '#login') location.hash = '#live';
      else route();
    });
    return;
  }
  nav.hidden = false;
  if (!stopSessionBar) stopSessionBar = startSessionBar(document.getElementById('session-bar'));
  const [name, argument] = location.hash.replace(/^#/, '').split('/');
  const page = PAGES[name] ?? PAGES.live;
  for (const link of nav.querySelectorAll('a')) {
    if (link.dataset.page === (PAGES[name] ? name : 'live')) link.setAttribute('aria-current', 'page');
    else link.removeAttribute('aria-current');
  }
  document.title = `${page.title} · Chromosphere`;
  show(page.mount, argument ? decodeURIComponent(argument) : undefined);
}

window.addEventListener('hashchange', route);
window.addEventListener('chromo:logged-out', () => {
  if (!loggedIn) return;
  loggedIn = false;
  route();
});
document.getElementById('logout').addEventListener('click', async () => {
  try {
    await api.logout();
  } finally {
    loggedIn = false;
    route();
  }
});
api.onConnectionChange((connected) => {
  banner.hidden = connected;
  banner.textContent = connected ? '' : 'The daemon does not answer: retrying every second…';
  document.body.classList.toggle('disconnected', !connected);
  if (connected && loggedIn) route();  // fresh data after the daemon returns
});

startTheme(document.getElementById('theme'));
loggedIn = await api.whoami();
route();
