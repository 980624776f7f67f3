/* Attribute and element helpers of the scene XML reader. */
#include "scenexml/scene_xml_internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

const char *xml_elname(xmlNodePtr n) { return (const char *)n->name; }

/* A name from the file as a message shows it: whole up to 64 bytes, else
 * its first 64 (not splitting a UTF-8 character) and "...". A 2,000-character
 * element name once filled the message before its reason. */
static const char *shown_name(const char *name, char *buf, size_t size)
{
    enum { SHOWN = 64 };
    size_t len = strlen(name), keep = SHOWN;
    if (len <= SHOWN || size < SHOWN + 4)
        return name;
    while (keep > 0 && ((unsigned char)name[keep] & 0xC0) == 0x80) /* a continuation byte */
        keep--;
    snprintf(buf, size, "%.*s...", (int)keep, name);
    return buf;
}

int xml_fail(xml_ctx *c, xmlNodePtr n, const char *fmt, ...)
{
    char what[2048], shown[80];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return rr_fail(c->err, "%s:%ld: <%s>: %s", c->name, xmlGetLineNo(n), shown_name(xml_elname(n), shown, sizeof shown),
                   what);
}

/* Refuses element k, which is none of the NULL-terminated `known`:
 * "unknown <what> (expected a, b or c)" and the nearest known name. */
int xml_unknown_element(xml_ctx *c, xmlNodePtr k, const char *what, const char *const *known)
{
    char expected[256] = "", near[128];
    size_t used = 0;
    for (int i = 0; known[i] && used < sizeof expected; i++)
        used += (size_t)snprintf(expected + used, sizeof expected - used, "%s%s",
                                 i == 0 ? "" : known[i + 1] ? ", " : " or ", known[i]);
    return xml_fail(c, k, "unknown %s (expected %s)%s", what, expected,
                    rr_did_you_mean(xml_elname(k), known, "<", ">", near, sizeof near));
}

/* Rejects attributes not in the NULL-terminated list (catches typos). */
int xml_check_attributes(xml_ctx *c, xmlNodePtr n, const char *const *allowed)
{
    for (xmlAttrPtr a = n->properties; a; a = a->next) {
        int ok = 0;
        for (const char *const *p = allowed; *p && !ok; p++)
            ok = !strcmp(*p, (const char *)a->name);
        char near[128], shown[80];
        if (!ok)
            return xml_fail(c, n, "unknown attribute '%s'%s", shown_name((const char *)a->name, shown, sizeof shown),
                            rr_did_you_mean((const char *)a->name, allowed, "", "", near, sizeof near));
    }
    return 0;
}

int xml_has_attr(xmlNodePtr n, const char *name) { return xmlHasProp(n, (const xmlChar *)name) != NULL; }

/* An external entity in an element's text is not read (no
 * XML_PARSE_NOENT: it could name any file), so the text would come out
 * empty and be blamed on something else ("point model has no splats"). */
static int text_uses_external_entity(xml_ctx *c, xmlNodePtr n)
{
    for (xmlNodePtr k = n->children; k; k = k->next) {
        if (k->type != XML_ENTITY_REF_NODE)
            continue;
        xmlEntityPtr e = xmlGetDocEntity(n->doc, k->name);
        if (!e || e->etype != XML_INTERNAL_GENERAL_ENTITY)
            return xml_fail(c, n, "its text uses the external XML entity '%s': external entities are not read",
                            (const char *)k->name);
    }
    return 0;
}

/* (libxml2 itself refuses external entities in attributes; internal ones
 * expand in xmlGetProp.) */
int xml_attr_text(xml_ctx *c, xmlNodePtr n, const char *name, char *buf, size_t size)
{
    xmlChar *v = xmlGetProp(n, (const xmlChar *)name);
    if (!v)
        return 0;
    size_t len = strlen((const char *)v);
    if (len >= size) {
        xmlFree(v);
        return xml_fail(c, n, "attribute '%s' is %zu characters long: at most %zu are read", name, len, size - 1);
    }
    memcpy(buf, v, len + 1);
    xmlFree(v);
    return 1;
}

/* Parses up to max whitespace-separated finite numbers; returns the count,
 * or -1 if a token is not a finite number. */
int xml_parse_numbers(const char *text, double *out, int max)
{
    int n = 0;
    const char *p = text;
    for (;;) {
        while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r' || *p == ',')
            p++;
        if (!*p)
            return n;
        char *end;
        double v = strtod(p, &end);
        if (end == p || !isfinite(v) || n == max)
            return -1;
        out[n++] = v;
        p = end;
    }
}

int xml_attr_number_list(xml_ctx *c, xmlNodePtr n, const char *name, double *out, int max, int *count)
{
    (void)c;
    xmlChar *v = xmlGetProp(n, (const xmlChar *)name); /* read whole: a number list has no length limit */
    *count = 0;
    if (!v)
        return 0;
    *count = xml_parse_numbers((const char *)v, out, max);
    xmlFree(v);
    return 1;
}

int xml_attr_numbers(xml_ctx *c, xmlNodePtr n, const char *name, double *out, int count,
                        int required)
{
    double got[4];
    int found;
    RR_CHECK(count <= 4);
    int rc = xml_attr_number_list(c, n, name, got, count, &found);
    if (rc <= 0)
        return rc < 0 ? -1 : required ? xml_fail(c, n, "missing required attribute '%s'", name) : 0;
    if (found != count) {
        xmlChar *v = xmlGetProp(n, (const xmlChar *)name);
        xml_fail(c, n, "attribute '%s' must be %d finite number%s, got '%.200s'", name, count, count > 1 ? "s" : "",
                 (const char *)v);
        xmlFree(v);
        return -1;
    }
    for (int i = 0; i < count; i++)
        out[i] = got[i];
    return 0;
}

int xml_attr_double(xml_ctx *c, xmlNodePtr n, const char *name, double *v, int required)
{
    return xml_attr_numbers(c, n, name, v, 1, required);
}

int xml_attr_vec3(xml_ctx *c, xmlNodePtr n, const char *name, vec3 *v, int required)
{
    double a[3] = {v->x, v->y, v->z};
    if (xml_attr_numbers(c, n, name, a, 3, required))
        return -1;
    *v = v3(a[0], a[1], a[2]);
    return 0;
}

int xml_attr_positive(xml_ctx *c, xmlNodePtr n, const char *name, double *v, int required)
{
    if (xml_attr_double(c, n, name, v, required))
        return -1;
    if (!(*v > 0))
        return xml_fail(c, n, "attribute '%s' must be positive", name);
    return 0;
}

int xml_attr_int(xml_ctx *c, xmlNodePtr n, const char *name, int *v, int lo, int hi)
{
    double d = *v;
    if (xml_attr_double(c, n, name, &d, 0))
        return -1;
    if (d != floor(d) || d < lo || d > hi)
        return xml_fail(c, n, "attribute '%s' must be an integer in [%d, %d]", name, lo, hi);
    *v = (int)d;
    return 0;
}

int xml_is_element(xmlNodePtr n) { return n->type == XML_ELEMENT_NODE; }

/* Non-blank text directly inside the element (a path, as in Figure 4.11)? */
/* Entity references and CDATA are text too: counting only text nodes
 * once left <animation>&ext;</animation> or a CDATA path static, the
 * animation dropped without a word. */
int xml_has_text(xmlNodePtr n)
{
    for (xmlNodePtr k = n->children; k; k = k->next)
        if (k->type == XML_ENTITY_REF_NODE ||
            ((k->type == XML_TEXT_NODE || k->type == XML_CDATA_SECTION_NODE) && !xmlIsBlankNode(k)))
            return 1;
    return 0;
}

/* Text children must be whitespace only, except where an element takes a
 * path as its content. */
int xml_check_no_text(xml_ctx *c, xmlNodePtr parent)
{
    return xml_has_text(parent) ? xml_fail(c, parent, "unexpected text inside this element") : 0;
}

/* Resolves rel against the scene's directory; a path that does not fit is
 * an error, never silently cut. */
int xml_resolve_path(xml_ctx *c, xmlNodePtr n, const char *rel, char *out, size_t size)
{
    int absolute = rel[0] == '/' || rel[0] == '\\' || !c->base_dir || !c->base_dir[0];
    int len = absolute ? snprintf(out, size, "%s", rel) : snprintf(out, size, "%s/%s", c->base_dir, rel);
    if (len < 0 || (size_t)len >= size)
        return xml_fail(c, n, "file path '%.60s...' resolves to %d characters: at most %zu are read",
                        rel, len, size - 1);
    for (char *p = out + (len - (int)strlen(rel)); *p; p++)
        if (*p == '\\')
            *p = '/'; /* thesis Figure 4.11 writes Windows paths */
    return 0;
}

/* The element's text with surrounding white space removed; 0 if empty,
 * -1 (an error naming the length) if too long for buf. */
int xml_element_text(xml_ctx *c, xmlNodePtr n, char *buf, size_t size)
{
    if (text_uses_external_entity(c, n))
        return -1;
    xmlChar *text = xmlNodeGetContent(n);
    int found = 0;
    if (text) {
        const char *s = (const char *)text;
        while (*s == ' ' || *s == '\n' || *s == '\t' || *s == '\r')
            s++;
        size_t len = strlen(s);
        while (len && (s[len - 1] == ' ' || s[len - 1] == '\n' || s[len - 1] == '\t' || s[len - 1] == '\r'))
            len--;
        if (len >= size)
            found = xml_fail(c, n, "its text is %zu characters long: at most %zu are read", len, size - 1);
        else if (len) {
            memcpy(buf, s, len);
            buf[len] = 0;
            found = 1;
        }
        xmlFree(text);
    }
    return found;
}
