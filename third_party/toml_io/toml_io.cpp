// toml_io.cpp - the C bridge over toml++; see toml_io.h.
//
// Debian ships toml++ as a shared library (libtomlplusplus.so.3, built with
// exceptions), so the header is used in its non-header-only mode and the
// program links with -ltomlplusplus.
#define TOML_HEADER_ONLY 0
#define TOML_SHARED_LIB 1
#define TOML_EXCEPTIONS 1
#include "toml_io.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include <toml++/toml.h>

namespace {

struct stored_value {
    toml_io_value value{};
    std::string text; // STRING payload; value.string points into it once frozen
};

struct stored_entry {
    std::string key;
    uint32_t line = 0, column = 0;
    size_t order = 0; // traversal order, breaks ties between equal positions
    stored_value value;
    size_t element_count = 0;
    std::vector<stored_value> elements;
    std::vector<toml_io_value> element_values; // handed out; built when frozen
};

void set_err(char *err, size_t errlen, const std::string &msg)
{
    if (!err || !errlen) return;
    // One line: newlines in a library message become spaces.
    std::string line = msg;
    for (char &c : line)
        if (c == '\n' || c == '\r') c = ' ';
    snprintf(err, errlen, "%s", line.c_str());
}

bool is_bare_key(std::string_view k)
{
    if (k.empty()) return false;
    for (unsigned char c : k) {
        bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                  c == '_' || c == '-';
        if (!ok) return false;
    }
    return true;
}

// A key segment as TOML would write it: bare when possible, else a basic string.
std::string key_segment(std::string_view k)
{
    if (is_bare_key(k)) return std::string(k);
    std::string out = "\"";
    for (unsigned char c : k) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += static_cast<char>(c);
        } else if (c < 0x20 || c == 0x7f) {
            char buf[8];
            snprintf(buf, sizeof buf, "\\u%04X", c);
            out += buf;
        } else {
            out += static_cast<char>(c);
        }
    }
    out += '"';
    return out;
}

stored_value scalar_of(const toml::node &n)
{
    stored_value v;
    switch (n.type()) {
    case toml::node_type::integer: {
        int64_t i = n.as_integer()->get();
        v.value.type = TOML_IO_INTEGER;
        v.value.integer = i;
        v.value.number = static_cast<double>(i);
        break;
    }
    case toml::node_type::floating_point:
        v.value.type = TOML_IO_FLOAT;
        v.value.number = n.as_floating_point()->get();
        break;
    case toml::node_type::boolean:
        v.value.type = TOML_IO_BOOLEAN;
        v.value.boolean = n.as_boolean()->get() ? 1 : 0;
        break;
    case toml::node_type::string:
        v.value.type = TOML_IO_STRING;
        v.text = n.as_string()->get();
        v.value.string_length = v.text.size();
        break;
    case toml::node_type::array:
        v.value.type = TOML_IO_ARRAY;
        break;
    case toml::node_type::table:
        v.value.type = TOML_IO_TABLE;
        break;
    default:
        v.value.type = TOML_IO_OTHER;
        break;
    }
    return v;
}

void flatten(const toml::table &table, const std::string &prefix, uint32_t parent_line,
             uint32_t parent_column, std::vector<stored_entry> &out)
{
    for (auto &&[k, node] : table) {
        stored_entry e;
        e.key = prefix.empty() ? key_segment(k.str()) : prefix + "." + key_segment(k.str());
        const toml::source_region &ks = k.source();
        const toml::source_region &ns = node.source();
        if (ks.begin.line) {
            e.line = ks.begin.line;
            e.column = ks.begin.column;
        } else if (ns.begin.line) {
            e.line = ns.begin.line;
            e.column = ns.begin.column;
        } else {
            e.line = parent_line;
            e.column = parent_column;
        }
        e.order = out.size();
        e.value = scalar_of(node);
        if (const toml::array *arr = node.as_array()) {
            e.element_count = arr->size();
            e.elements.reserve(arr->size());
            for (const toml::node &el : *arr) e.elements.push_back(scalar_of(el));
            out.push_back(std::move(e));
        } else if (const toml::table *sub = node.as_table()) {
            e.element_count = sub->size();
            std::string path = e.key;
            uint32_t line = e.line, column = e.column;
            out.push_back(std::move(e));
            flatten(*sub, path, line, column, out);
        } else {
            out.push_back(std::move(e));
        }
    }
}

bool read_file(const char *path, std::string &text, std::string &why)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        why = strerror(errno);
        return false;
    }
    char buf[65536];
    size_t n;
    errno = 0;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
    bool failed = ferror(f) != 0;
    int saved = errno;
    fclose(f);
    if (failed) {
        why = saved ? strerror(saved) : "read error";
        return false;
    }
    return true;
}

} // namespace

struct toml_io_doc {
    std::vector<stored_entry> entries;
};

extern "C" int toml_io_parse_file(const char *path, toml_io_doc **out, char *err, size_t errlen)
{
    *out = nullptr;
    try {
        std::string text, why;
        if (!read_file(path, text, why)) {
            set_err(err, errlen, why);
            return TOML_IO_READ;
        }
        toml::table root;
        try {
            root = toml::parse(text, std::string(path));
        } catch (const toml::parse_error &e) {
            const toml::source_position &p = e.source().begin;
            set_err(err, errlen,
                    "line " + std::to_string(p.line) + ", column " + std::to_string(p.column) +
                        ": " + std::string(e.description()));
            return TOML_IO_SYNTAX;
        }
        toml_io_doc *doc = new toml_io_doc;
        flatten(root, "", 1, 1, doc->entries);
        // Document order: toml++ keeps each table's keys sorted by name, so the
        // entries are ordered by where their keys stand in the file. A table
        // shares its position with its first dotted child only in "a.b = 1",
        // where traversal order already puts the table first.
        std::stable_sort(doc->entries.begin(), doc->entries.end(),
                         [](const stored_entry &a, const stored_entry &b) {
                             if (a.line != b.line) return a.line < b.line;
                             if (a.column != b.column) return a.column < b.column;
                             return a.order < b.order;
                         });
        // Freeze: every pointer handed out now refers to storage that no longer moves.
        for (stored_entry &e : doc->entries) {
            if (e.value.value.type == TOML_IO_STRING) e.value.value.string = e.value.text.c_str();
            e.element_values.reserve(e.elements.size());
            for (stored_value &v : e.elements) {
                if (v.value.type == TOML_IO_STRING) v.value.string = v.text.c_str();
                e.element_values.push_back(v.value);
            }
        }
        *out = doc;
        return TOML_IO_OK;
    } catch (const std::bad_alloc &) {
        set_err(err, errlen, "out of memory");
        return TOML_IO_NOMEM;
    } catch (const std::exception &e) {
        set_err(err, errlen, e.what());
        return TOML_IO_SYNTAX;
    }
}

extern "C" void toml_io_free(toml_io_doc *doc) { delete doc; }

extern "C" size_t toml_io_count(const toml_io_doc *doc) { return doc ? doc->entries.size() : 0; }

extern "C" int toml_io_get(const toml_io_doc *doc, size_t index, toml_io_entry *out)
{
    if (!doc || index >= doc->entries.size()) return -1;
    const stored_entry &e = doc->entries[index];
    out->key = e.key.c_str();
    out->line = e.line;
    out->column = e.column;
    out->value = e.value.value;
    out->element_count = e.element_count;
    out->elements = e.element_values.empty() ? nullptr : e.element_values.data();
    return 0;
}
