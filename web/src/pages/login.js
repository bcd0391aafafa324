// Log-in: the daemon's configured token, exchanged for an HttpOnly cookie.
import * as api from '../api.js';
import { h, field, messageArea } from '../dom.js';

export function mountLogin(container, onLoggedIn) {
  const token = h('input', { type: 'password', name: 'token', autocomplete: 'current-password', required: true });
  const message = messageArea();
  const form = h('form', { class: 'login', 'aria-labelledby': 'login-heading' },
    h('h2', { id: 'login-heading' }, 'Log in'),
    h('p', {}, 'Enter the token from chromod\'s configuration (docs/config.md, "token").'),
    field('Token', token),
    h('button', { type: 'submit' }, 'Log in'),
    message.element);
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    message.clear();
    try {
      await api.login(token.value);
      onLoggedIn();
    } catch (error) {
      message.error(error);
      token.select();
    }
  });
  container.append(form);
  token.focus();
}
