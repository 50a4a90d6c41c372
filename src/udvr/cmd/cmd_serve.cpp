// udvr serve MODEL [--tf TF|PRESET] [--truth FIELD] [--second MODEL2 --tf2 TF2] [--port 8080]
//            [--host 127.0.0.1]   — the interactive viewer in a browser (SPEC §8, docs/serve.md)
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/option_flags.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/serve/api.h"
#include "udvr/serve/http_server.h"
#include "udvr/serve/request_guard.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

void addServeCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "serve",
        "explore a model in the browser: orbit, edit the TF, switch models, probe (docs/serve.md)");
    struct Opts {
        std::string model, truth, var;
        RenderOptions options;  // --second, --second-var, --force (render/render_options.h)
        serve::HttpOptions http;
        TfFlags tf;
        Tf2Flags tf2;
        RawLayoutFlags raw;
    };
    auto o = std::make_shared<Opts>();
    sub->add_option(
           "model", o->model,
           "model (.vti or .pvti from `udvr build`) or a plain field (.vti .nc .nrrd .nhdr .raw)")
        ->required();
    addTfOptions(sub, o->tf);
    addTf2Options(sub, o->tf2);
    addOptionFlags(sub, forceOptionSpecs(), o->options);
    sub->add_option("--truth", o->truth,
                    "ground-truth field: shown beside the model with the difference image and "
                    "the RMSE (SPEC 6)");
    addOptionFlags(sub, bivariateOptionSpecs(), o->options);
    sub->add_option("--port", o->http.port, "TCP port (default 8080; 0 picks a free one)")
        ->check(wholeNumberIn(0, 65535));
    sub->add_option("--host", o->http.host,
                    "address to listen on (default 127.0.0.1: this machine only)");
    sub->add_option("--allow-host", o->http.allowHosts,
                    "a Host name requests may carry besides loopback names and addresses (a "
                    "reverse proxy's public name; repeatable; '*': any). Others get 403, as do "
                    "pages of other origins")
        ->allow_extra_args(false)
        ->take_all();
    sub->add_option("--read-timeout", o->http.readTimeout,
                    "seconds a request's head and body may take to arrive (default 10)")
        ->check(CLI::Range(0.1, 3600.0));
    sub->add_option("--write-timeout", o->http.writeTimeout,
                    "seconds a client may take to receive a response (default 60)")
        ->check(CLI::Range(0.1, 3600.0));
    sub->add_option("--max-connections", o->http.maxConnections,
                    "connections open at once (default 64; at the cap the one that has waited "
                    "longest for its request is closed, or the new one gets 503)")
        ->check(CLI::Range(4, 512));
    sub->add_option("--max-header", o->http.maxHeaderBytes,
                    "bytes of a request's line and headers (default 65536; more: 431)")
        ->check(CLI::Range(std::size_t{1024}, std::size_t{1} << 24));
    sub->add_option("--max-body", o->http.maxBodyBytes,
                    "bytes of a POST body, any transfer encoding (default 1048576; more: 413)")
        ->check(CLI::Range(std::size_t{1024}, std::size_t{1} << 30));
    sub->add_option("--var", o->var, "array/variable name in the inputs");
    addRawLayoutOptions(sub, o->raw);
    sub->callback([o] {
        requireOneTf(o->tf.tf, o->tf2);
        const bool twoD = !o->tf2.file.empty();
        checkTfFlags(o->tf, twoD);
        checkBivariateOptions(o->options, twoD);
        const std::string& second = o->options.second;
        if (!second.empty() && !o->truth.empty())
            UDVR_FAIL("--truth compares one field with the model; it does not go with --second");
        serve::ServeData data;
        TfChoice tfChoice;  // a TF file is read before the volume, so a bad one costs nothing
        if (!twoD && !tfIsPreset(o->tf)) tfChoice.tf = readTransferFunctionFile(o->tf);
        if (twoD)
            data.tf2 =
                readTransferFunction2D(o->tf2.file, toTf2ReadOptions(o->tf2, o->options.force));
        if (twoD && lowerExtension(o->tf2.file) == ".json") {  // the page edits the widgets
            std::ifstream in(o->tf2.file, std::ios::binary);
            data.tf2Widgets.assign(std::istreambuf_iterator<char>(in), {});
            if (!in && !in.eof()) UDVR_FAIL("cannot read " << o->tf2.file);
        }
        data.tf2File = o->tf2.file;
        data.model = readModelOrField(o->model, o->var, o->raw);
        data.modelFile = o->model;
        // With --tf2 the 1D TF is the default preset, for the page's editor only.
        if (twoD || tfIsPreset(o->tf))
            tfChoice = chooseTransferFunction(twoD ? TfFlags{} : o->tf, data.model, "serve");
        data.tf = tfChoice.tf;
        if (!o->truth.empty()) {
            data.truth = readModelOrField(o->truth, o->var, o->raw);
            data.truthFile = o->truth;
        }
        if (!second.empty()) {
            data.second = readModelOrField(second, secondFieldVar(o->options, o->var), o->raw);
            data.secondFile = second;
        }
        const std::string& host = o->http.host;
        if (host != "127.0.0.1" && host != "localhost" && host != "::1") {
            std::fprintf(stderr,
                         "serve: warning: listening on %s: whoever reaches this address can use "
                         "the viewer (no authentication)\n",
                         host.c_str());
            // Requests naming the address it listens on are the server's own.
            if (host != "0.0.0.0" && host != "::" && !host.empty())
                o->http.allowHosts.push_back(serve::hostNameOf(
                    host.find(':') != std::string::npos ? "[" + host + "]" : host));
        }
        data.maxBodyBytes = o->http.maxBodyBytes;
        serve::Api api(std::move(data));
        serve::runHttpServer(api, o->http, [&](int port) {
            if (!twoD) finishTransferFunction(o->tf, tfChoice);  // --save-tf, the preset's note
            const std::string shown = host.find(':') != std::string::npos ? "[" + host + "]" : host;
            std::printf("udvr serve: http://%s:%d/ (Ctrl-C stops)\n", shown.c_str(), port);
            std::fflush(stdout);
        });
    });
}

}  // namespace udvr::cmd
