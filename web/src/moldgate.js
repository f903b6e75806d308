// The glue between JavaScript and moldgate's WebAssembly module (crates/moldgate-web): plain
// exports over integers and byte ranges, no generated bindings. Every call that produces
// something returns a status (non-zero on success) and leaves its bytes, or the error message,
// in one output buffer (mg_out_ptr, mg_out_len). A panic traps the call: the module's panic
// hook hands the message over first, and the instance is replaced by a fresh one.

const decoder = new TextDecoder();
const encoder = new TextEncoder();

/** An error of the module: `message` is moldgate's; `trapped` when the instance was replaced. */
export class MoldgateError extends Error {
  constructor(message, trapped = false) {
    super(message);
    this.name = "MoldgateError";
    this.trapped = trapped;
  }
}

export class Moldgate {
  /** Compiles the module at `url` once; `onProgress(stage, fraction)` hears the study's stages. */
  static async load(url, onProgress = () => {}) {
    const response = await fetch(url);
    if (!response.ok) throw new MoldgateError(`cannot load ${url}: HTTP ${response.status}`);
    return Moldgate.fromBytes(await response.arrayBuffer(), onProgress);
  }

  /** The same from the module's bytes. */
  static async fromBytes(bytes, onProgress = () => {}) {
    const mg = new Moldgate(await WebAssembly.compile(bytes), onProgress);
    await mg.instantiate();
    return mg;
  }

  constructor(module, onProgress) {
    this.module = module;
    this.onProgress = onProgress;
    this.panic = null;
  }

  async instantiate() {
    const imports = {
      moldgate: {
        now_ms: () => performance.now(),
        progress: (ptr, len, fraction) => this.onProgress(this.text(ptr, len), fraction),
        panicked: (ptr, len) => {
          this.panic = this.text(ptr, len);
        },
      },
    };
    this.instance = await WebAssembly.instantiate(this.module, imports);
    this.x = this.instance.exports;
    this.x.mg_init();
  }

  text(ptr, len) {
    return decoder.decode(new Uint8Array(this.x.memory.buffer, ptr, len));
  }

  out() {
    return new Uint8Array(this.x.memory.buffer, this.x.mg_out_ptr(), this.x.mg_out_len()).slice();
  }

  /** Runs `f` (which calls exports); a trap becomes a MoldgateError and a fresh instance. */
  async call(f) {
    let status;
    try {
      this.panic = null;
      status = f();
    } catch (e) {
      if (!(e instanceof WebAssembly.RuntimeError)) throw e;
      const mb = (this.x.memory.buffer.byteLength / 2 ** 20).toFixed(0);
      const message = this.panic
        ? `moldgate stopped on an internal error: ${this.panic}`
        : `moldgate stopped (${e.message}) with ${mb} MB of memory in use: the part or the grid ` +
          `is probably too large for the browser's memory; try a coarser spacing or cell`;
      await this.instantiate();
      throw new MoldgateError(message, true);
    }
    if (status === 0) throw new MoldgateError(decoder.decode(this.out()));
    return status;
  }

  /** Copies `bytes` into the module, runs `f(ptr, len)`, and frees them. */
  withBytes(bytes, f) {
    const ptr = this.x.mg_alloc(bytes.length);
    if (ptr === 0) throw new MoldgateError(`not enough memory for ${bytes.length} bytes`);
    new Uint8Array(this.x.memory.buffer, ptr, bytes.length).set(bytes);
    let result;
    try {
      result = f(ptr, bytes.length);
    } catch (e) {
      // After a trap the instance is replaced with its memory: nothing to free.
      if (!(e instanceof WebAssembly.RuntimeError)) this.x.mg_free(ptr, bytes.length);
      throw e;
    }
    this.x.mg_free(ptr, bytes.length);
    return result;
  }

  /** Studies a file's bytes (or a sample) as `request` asks; returns the study's handle. A
   * refusal's error has `fileError` when the file cannot be read (no option mends it). */
  async study(bytes, request) {
    const req = encoder.encode(JSON.stringify(request));
    const x = () => this.x;
    try {
      return await this.call(() =>
        this.withBytes(bytes, (fp, fl) => this.withBytes(req, (rp, rl) => x().mg_study(fp, fl, rp, rl)))
      );
    } catch (e) {
      if (e instanceof MoldgateError && !e.trapped) e.fileError = this.x.mg_error_is_file() === 1;
      throw e;
    }
  }

  /** Checks `request`'s options as a study would before it reads the file; throws the
   * library's message when one is refused. */
  async check(request) {
    const req = encoder.encode(JSON.stringify(request));
    await this.call(() => this.withBytes(req, (rp, rl) => this.x.mg_check(rp, rl)));
  }

  async bytes(f) {
    await this.call(f);
    return this.out();
  }

  async json(f) {
    return JSON.parse(decoder.decode(await this.bytes(f)));
  }

  report(h) { return this.bytes(() => this.x.mg_report(h)).then((b) => decoder.decode(b)); }
  glb(h, colouring) { return this.bytes(() => this.x.mg_glb(h, colouring)); }
  png(h, colouring) { return this.bytes(() => this.x.mg_png(h, colouring)); }
  html(h, colouring) { return this.bytes(() => this.x.mg_html(h, colouring)); }
  drop(h) { this.x.mg_drop(h); }
  samples() { return this.json(() => this.x.mg_samples()); }
  materials() { return this.json(() => this.x.mg_materials()); }
  /** The materials with a user's materials file `{name, text}` (TOML): its materials replace
   * the built-ins of their names, the others follow. */
  materialsWith(file) {
    const req = encoder.encode(JSON.stringify(file));
    return this.json(() => this.withBytes(req, (p, l) => this.x.mg_materials_with(p, l)));
  }
  defaults() { return this.json(() => this.x.mg_defaults()); }
  version() { return this.bytes(() => this.x.mg_version()).then((b) => decoder.decode(b)); }
  maxFileBytes() { return this.x.mg_max_file_bytes(); }
  threads() { return this.x.mg_threads(); }
}
